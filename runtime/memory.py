"""How much memory a run will take, estimated before it allocates any of it, and its budget.

A CEM iteration simulates all its samples at once and the simulator keeps what they produce
(runtime/simulate.py): the state after every physics step of every sample (samples x steps x
full physics state), and at each recorded time point the state, a sensing row (MuJoCo's
integration state and every sensor value) with its copy, and the decoded `Frames` (an
entities x entities contact matrix, poses, velocities, finger normals). The buffers only grow and
last the whole run, one set for the planning simulator (the CEM's rollouts at the planning
timestep) and one for the executing one (the final elites run again at the world's timestep), so
the peak is the base (interpreter, MuJoCo, model copies, one MjData per thread) plus the largest
phase of each. So memory scales with samples x motion length / timestep x (state size + the
sensors and entities per recorded point), and the state, the sensors and the contact matrix all
grow with the scene's objects.

A motion lasts its `duration`, plus `grip_dwell` at every keypoint (taken as if every keypoint
changed the grip: what a keypoint's grip is is known only when the phase starts), plus `settle`.
The estimate is checked against MAX_RUN_BYTES (rapid_dsl/language/limits.py) before a run starts;
docs/running.md compares it with measured peaks.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco

from rapid_dsl.language.limits import MAX_RUN_BYTES
from rapid_dsl.runtime.config import RunConfig
from rapid_dsl.runtime.program import Primitive, Program
from rapid_dsl.runtime.scenes.world import World

BASE_BYTES = 110 * 10**6    # the interpreter, numpy, MuJoCo and a compiled program (measured)
MODEL_COPIES = 8            # models the simulators and their sensing batches copy
DATAS_PER_THREAD = 4        # MjData of the two simulators' rollout pools and sensing batches
FLOAT = 8
_GB = 1e9


class MemoryBudgetError(ValueError):
    """The run's estimated memory is above MAX_RUN_BYTES; the message says which knob to turn."""


@dataclass(frozen=True, slots=True)
class Sizes:
    """Per-sample sizes of one world's simulation."""

    nstate: int         # full physics state (kept after every step)
    nrow: int           # a sensing batch's row (MuJoCo's integration state)
    nsensordata: int
    nu: int
    entities: int
    objects: int
    fixed: int          # bytes that do not depend on the samples: base, models, MjData per thread

    @staticmethod
    def of(world: World, nthread: int) -> Sizes:
        model = world.model
        data = mujoco.MjData(model)
        # an MjData's arena (contacts, constraints) is reserved whole and touched in part
        per_data = data.nbuffer + model.narena // 8
        fixed = (BASE_BYTES + MODEL_COPIES * model.nbuffer
                 + DATAS_PER_THREAD * max(1, nthread) * per_data)
        return Sizes(mujoco.mj_stateSize(model, mujoco.mjtState.mjSTATE_FULLPHYSICS),
                     mujoco.mj_stateSize(model, mujoco.mjtState.mjSTATE_INTEGRATION),
                     model.nsensordata, model.nu, len(world.entities.entities),
                     len(world.scene.objects), fixed)

    def rollout(self, batch: int, steps: int, frames: int, ticks: int, knots: int) -> int:
        """Bytes a simulator holds after simulating `batch` samples of `steps` physics steps,
        recording `frames` time points, from controls of `ticks` control ticks."""
        kept = batch * steps * (self.nstate + self.nu) * FLOAT          # states and controls
        recorded = batch * frames * ((self.nstate + self.nrow + 2 * self.nsensordata) * FLOAT
                                     + self.entities * self.entities      # contacts (bool)
                                     + self.entities * 154)               # poses, fingers
        targets = batch * ticks * (knots + 24) * FLOAT                  # hand targets
        return kept + recorded + targets


@dataclass(frozen=True, slots=True)
class Estimate:
    bytes: int
    phase: str          # the phase that plans the most
    samples: int
    steps: int          # its planning physics steps per sample
    sizes: Sizes

    def message(self, limit: int, fits: int, copies: int = 1) -> str:
        """Why the run is refused and what to turn: samples, duration, timestep, objects."""
        fit = f"at most {fits} fit" if fits else "not even 1 fits this motion"
        knobs = [f"lower --samples ({fit})", "shorten the motion (`motion { duration }`)",
                 "plan at a coarser --planning-dt", "use fewer objects"]
        needs = f"the run needs about {self.bytes / _GB:.1f} GB"
        if copies > 1:
            needs = (f"{copies} runs at once need about {copies * self.bytes / _GB:.1f} GB "
                     f"({self.bytes / _GB:.1f} GB each)")
            knobs.append("run fewer --jobs")
        return (f"{needs} of memory, more than the limit of {limit / _GB:.1f} GB: phase "
                f"`{self.phase}` simulates {self.samples} samples x {self.steps:,} planning steps "
                f"of a scene of {self.sizes.objects} objects (a state of {self.sizes.nstate:,} "
                f"numbers, {self.sizes.nsensordata:,} sensor values); "
                + ", ".join(knobs[:-1]) + f" or {knobs[-1]}")


def estimate(program: Program, world: World, entry: str, config: RunConfig,
             samples: int | None = None) -> Estimate:
    """The peak memory of running `entry` on `world` with `config` (`samples` overrides the
    config's and the primitives' population, to find how many fit)."""
    decl = program.declaration(entry)
    primitives = [(decl.name, decl)] if isinstance(decl, Primitive) else \
        [(p.name, program.primitive(p.primitive)) for p in decl.phases]
    sizes = Sizes.of(world, config.nthread)
    control_dt = world.dt * config.control_steps
    planning_dt = config.planning_dt or world.dt
    per_tick = round(control_dt / planning_dt)
    planned = executed = 0
    worst = ("", 0, 0, -1)
    for name, primitive in primitives:
        count = samples or config.samples or primitive.optimize.samples
        elites = max(1, min(primitive.optimize.elites, count // 2 or 1))
        runs = min(config.execute_elites or elites, elites)
        keypoints = len(primitive.motion.names)
        total = primitive.motion.duration + config.grip_dwell * keypoints + config.settle
        ticks = math.ceil(total / control_dt - 1e-9)
        knots = 2 * keypoints + 1
        plan = sizes.rollout(count, ticks * per_tick,
                             _frames(ticks * per_tick, per_tick * config.frame_ticks),
                             ticks, knots)
        run = sizes.rollout(runs if runs > 1 else 0, ticks * config.control_steps,
                            _frames(ticks * config.control_steps,
                                    config.control_steps * config.frame_ticks), ticks, knots)
        executed = max(executed, run)
        planned = max(planned, plan)
        if plan > worst[3]:
            worst = (name, count, ticks * per_tick, plan)
    if per_tick == config.control_steps:   # one simulator plans and executes
        planned, executed = max(planned, executed), 0
    return Estimate(sizes.fixed + planned + executed, worst[0], worst[1], worst[2], sizes)


def check(program: Program, world: World, entry: str, config: RunConfig, *,
          copies: int = 1) -> Estimate:
    """The estimate; MemoryBudgetError when `copies` runs at once (verify's parallel jobs)
    would need more than MAX_RUN_BYTES."""
    found = estimate(program, world, entry, config)
    if copies * found.bytes > MAX_RUN_BYTES:
        fits = _samples_that_fit(program, world, entry, config, copies)
        raise MemoryBudgetError(found.message(MAX_RUN_BYTES, fits, copies))
    return found


def _samples_that_fit(program: Program, world: World, entry: str, config: RunConfig,
                      copies: int) -> int:
    """The largest population every phase could use within the budget (0: not even one)."""
    low, high = 0, 1 << 20
    while low < high:
        middle = (low + high + 1) // 2
        if copies * estimate(program, world, entry, config, middle).bytes <= MAX_RUN_BYTES:
            low = middle
        else:
            high = middle - 1
    return low


def _frames(steps: int, every: int) -> int:
    """Time points a rollout of `steps` steps records every `every` steps (the last always)."""
    return steps // every + 1 + (steps % every != 0)


__all__ = ["Estimate", "MemoryBudgetError", "check", "estimate"]
