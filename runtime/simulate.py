"""Batched MuJoCo rollouts that return `Frames`.

`Simulator.rollout` runs B open-loop control sequences from one (or B) start states on MuJoCo's
native thread pool (`mujoco.rollout.Rollout`, created once) into reused buffers, then evaluates the
sensors of the recorded time points with one native forward pass each (`mujoco.batch.Batch`) and
decodes them into a `Frames` with numpy: no Python loop over samples or steps. The steps run with
MuJoCo's sensor stage disabled: sensors never feed back into the dynamics, so this changes no
state and saves their cost on every step.

Timing: `ctrl[:, k]` is applied during physics step k (k = 0 .. nstep-1, each `Simulator.dt` long:
the world's timestep, or the one the Simulator was made with).
Frames time index j holds the state at t = j * record_every * dt since the start; index 0 is the
start state and the last index is always the state after all nstep steps.

A rollout that diverges (NaN/huge accelerations; MuJoCo resets it) is flagged in
`Simulator.unstable` (B,) after the call, and its float Frames arrays are NaN from the first bad
time point on, so costs computed from them are NaN rather than plausible.
"""

from __future__ import annotations

import copy
import logging
from typing import Self, cast

import mujoco
import numpy as np
from mujoco import rollout as mj_rollout
from mujoco.batch import Batch

from rapid_dsl.runtime.frames import Frames
from rapid_dsl.runtime.scenes.world import World

STATE_SPEC = mujoco.mjtState.mjSTATE_FULLPHYSICS
ROW_SPEC = mujoco.mjtState.mjSTATE_INTEGRATION   # what a Batch simulation's state row holds
NO_SENSORS = int(mujoco.mjtDisableBit.mjDSBL_SENSOR)
# What the sensors of a world never read (they are frame poses and velocities, contacts and joint
# positions): a forward pass for sensors skips these forces and constraint rows.
_D = mujoco.mjtDisableBit
NOT_SENSED = sum(int(bit) for bit in (_D.mjDSBL_EQUALITY, _D.mjDSBL_LIMIT, _D.mjDSBL_FRICTIONLOSS,
                                      _D.mjDSBL_ACTUATION, _D.mjDSBL_DAMPER, _D.mjDSBL_SPRING,
                                      _D.mjDSBL_GRAVITY))
STAGE_VEL = mujoco.mjtStage.mjSTAGE_VEL.value     # every sensor of the world is pos/vel stage


_log = logging.getLogger("rapid_dsl.runtime.mujoco")


def _route_mujoco_warnings() -> None:
    """Send MuJoCo's warnings to logging instead of stdout and ./MUJOCO_LOG.TXT.

    A diverging sample is an expected event during CEM (reported through `unstable`), so its
    warning is debug information. A handler installed by the application is left alone.
    """
    if mujoco.get_mju_user_warning() is None:
        mujoco.set_mju_user_warning(lambda message: _log.debug("MuJoCo: %s", message.strip()))


def hold(ctrl: np.ndarray, every: int) -> np.ndarray:
    """Zero-order hold: (..., K, nu) coarse controls -> (..., K * every, nu) at the physics rate."""
    return np.repeat(np.asarray(ctrl, dtype=float), every, axis=-2)


class Simulator:
    """Rollouts of one world. Not thread-safe: one Simulator per thread of control."""

    def __init__(self, world: World, *, nthread: int = 2, timestep: float | None = None):
        """`timestep` [s] simulates a copy of the world's model with that timestep instead."""
        self.world = world
        self.model = world.model
        if timestep is not None and timestep != world.dt:
            self.model = _with_timestep(world.model, timestep)
        self.dt = float(self.model.opt.timestep)
        self.nthread = nthread
        self.nstate = mujoco.mj_stateSize(self.model, STATE_SPEC)
        self.nsensordata = self.model.nsensordata
        self.unstable: np.ndarray = np.zeros(0, dtype=bool)   # (B,) of the last rollout or replay
        self.steps = 0                            # physics steps simulated so far
        _route_mujoco_warnings()
        self._stepping = stepping_model(world, timestep)
        self._pool = mj_rollout.Rollout(nthread=nthread)
        self._datas = [mujoco.MjData(self._stepping) for _ in range(max(1, nthread))]
        self._models: list[mujoco.MjModel] = []
        self._buffers: dict[str, np.ndarray] = {}   # inputs and outputs of the native rollout
        self._sensing: Batch | None = None          # grows to the most states sensed at once
        self._sensed = copy.copy(self.model)
        self._sensed.opt.disableflags |= NOT_SENSED
        # a row is the start state's physics inside a reset MjData's full integration state
        data = mujoco.MjData(self.model)
        self._row0 = np.empty(mujoco.mj_stateSize(self.model, ROW_SPEC))
        mujoco.mj_getState(self.model, data, self._row0, ROW_SPEC)
        self._physics = _components(self.model, ROW_SPEC, STATE_SPEC)

    # --- states ------------------------------------------------------------------------------

    def initial_state(self, data: mujoco.MjData | None = None) -> np.ndarray:
        """(nstate,) full physics state of `data`, or of the world's start state."""
        if data is None:
            data = self.world.make_data()
        state = np.empty(self.nstate)
        mujoco.mj_getState(self.model, data, state, STATE_SPEC)
        return state

    def set_state(self, data: mujoco.MjData, state: np.ndarray) -> None:
        """Load a full physics state into `data` and recompute derived quantities."""
        mujoco.mj_setState(self.model, data, np.asarray(state, dtype=float), STATE_SPEC)
        mujoco.mj_forward(self.model, data)

    def state_time(self, state: np.ndarray) -> np.ndarray:
        """Simulation time stored in a state (..., nstate) [s]."""
        return np.asarray(state)[..., 0]  # mjSTATE_TIME is the first field of the state

    # --- rollouts ----------------------------------------------------------------------------

    def rollout(self, state0: np.ndarray, ctrl: np.ndarray, *, record_every: int) -> Frames:
        """Simulate ctrl (B, nstep, nu) from state0 (nstate,) or (B, nstate); see module doc."""
        ctrl = np.asarray(ctrl, dtype=float)
        if ctrl.ndim != 3 or ctrl.shape[2] != self.model.nu or ctrl.shape[1] < 1:
            raise ValueError(f"ctrl must be (B, nstep >= 1, {self.model.nu}), got {ctrl.shape}")
        if record_every < 1:
            raise ValueError("record_every must be >= 1")
        batch, nstep, _ = ctrl.shape
        state0 = np.asarray(state0, dtype=float)
        if state0.shape not in ((self.nstate,), (batch, self.nstate)):
            raise ValueError(f"state0 must be ({self.nstate},) or ({batch}, {self.nstate}), "
                             f"got {state0.shape}")
        index = _record_index(nstep, record_every)
        sensed, _ = self._simulate(state0, ctrl, index)
        return self._decode(sensed, index, self.state_time(state0).reshape(-1, 1))

    def replay(self, state0: np.ndarray, ctrl: np.ndarray, *, record_every: int = 1,
               data: mujoco.MjData | None = None) -> tuple[np.ndarray, Frames]:
        """Run one control sequence ctrl (nstep, nu); returns (final state, Frames with B=1).

        The physics is the same code path as `rollout`, so the result equals that sample of a
        batch bit for bit. If `data` is given it is left in the final state.
        """
        ctrl = np.asarray(ctrl, dtype=float)
        if ctrl.ndim != 2:
            raise ValueError(f"ctrl must be (nstep, nu), got {ctrl.shape}")
        state0 = np.asarray(state0, dtype=float)
        index = _record_index(ctrl.shape[0], record_every)
        sensed, states = self._simulate(state0, ctrl[None], index)
        frames = self._decode(sensed, index, self.state_time(state0).reshape(1, 1))
        final = states[0, -1].copy()
        if data is not None:
            self.set_state(data, final)
        return final, frames

    def trajectory(self, state0: np.ndarray, ctrl: np.ndarray, *, every: int = 1) -> np.ndarray:
        """(T, nstate) full states of one run at the time points `replay` records (to render)."""
        ctrl = np.asarray(ctrl, dtype=float)
        if ctrl.ndim != 2:
            raise ValueError(f"ctrl must be (nstep, nu), got {ctrl.shape}")
        index = _record_index(ctrl.shape[0], every)
        _, states = self._simulate(np.asarray(state0, dtype=float), ctrl[None], index)
        return states[0]

    def close(self) -> None:
        """Stop the native thread pools (also happens when the Simulator is collected)."""
        self._pool.close()
        self._sensing = None

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # --- internals ---------------------------------------------------------------------------

    def _simulate(self, state0: np.ndarray, ctrl: np.ndarray,
                  index: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Step ctrl (B, nstep, nu) from state0; (B, T, nsensordata) sensors and (B, T, nstate)
        states at the T step indices."""
        batch, nstep, nu = ctrl.shape
        if len(self._models) < batch:
            self._models = [self._stepping] * batch
        control = ctrl
        if not (ctrl.flags.c_contiguous and ctrl.dtype == np.float64):
            control = self._buffer("ctrl", (batch, nstep, nu))
            control[:] = ctrl
        init = self._buffer("init", (batch, self.nstate))
        init[:] = state0
        after = self._buffer("states", (batch, nstep, self.nstate))   # after each step
        # chunks of one rollout: the threads take the next as they finish, evening out the load
        self._pool.rollout(self._models[:batch], self._datas, init, control, skip_checks=True,
                           nstep=nstep, control_spec=mujoco.mjtState.mjSTATE_CTRL.value,
                           initial_warmstart=None, state=after, chunk_size=1)
        self.steps += batch * nstep
        states = np.empty((batch, len(index), self.nstate))
        states[:, 0] = init           # index[0] is the start, index[1:] - 1 the steps ending there
        states[:, 1:] = after[:, index[1:] - 1]
        sensed = self._sense(states.reshape(-1, self.nstate))
        return sensed.reshape(batch, len(index), -1), states

    def _sense(self, states: np.ndarray) -> np.ndarray:
        """(n, nsensordata) sensors of full physics states (n, nstate), one forward pass each."""
        n = states.shape[0]
        if self._sensing is None or self._sensing.nsim < n:
            self._sensing = Batch(self._sensed, max(n, 64), nthread=max(1, self.nthread))
            self._sensing.bind("sensordata")   # registered before the first call
        rows = self._sensing.state[:n]
        rows[:] = self._row0
        rows[:, self._physics] = states
        ids = None if n == self._sensing.nsim else np.arange(n)
        self._sensing.forward(ids, stage=STAGE_VEL)
        return self._sensing.bind("sensordata")[:n].copy()

    def _buffer(self, name: str, shape: tuple[int, ...]) -> np.ndarray:
        """A C-contiguous array view of a reused flat buffer that only ever grows."""
        size = int(np.prod(shape))
        flat = self._buffers.get(name)
        if flat is None or flat.size < size:
            flat = self._buffers[name] = np.empty(size)
        return flat[:size].reshape(shape)

    def _decode(self, sensed: np.ndarray, index: np.ndarray, time0: np.ndarray) -> Frames:
        """(B, T, nsensordata) at step indices `index` -> Frames; flags diverged samples."""
        layout = self.world.sensors
        batch, steps = sensed.shape[:2]
        n_entities = len(self.world.entities.entities)
        dt = self.dt
        # MuJoCo resets a diverged simulation, so its clock stops matching the step count
        expected = time0 + index * dt
        bad = np.abs(sensed[..., layout.clock] - expected) > 0.5 * dt
        self.unstable = cast(np.ndarray, bad.any(axis=1))   # `bad` is (B, T): never a scalar
        pos = sensed[..., layout.pos]
        quat = sensed[..., layout.quat]
        linvel = sensed[..., layout.linvel]
        angvel = sensed[..., layout.angvel]
        opening = sensed[..., layout.fingers].sum(axis=-1)
        if self.unstable.any():
            after = np.cumsum(bad, axis=1) > 0
            for array in (pos, quat, linvel, angvel):
                array[after] = np.nan
            opening[after] = np.nan
        touching = sensed[..., layout.contact] > 0.5
        contact = np.zeros((batch, steps, n_entities, n_entities), dtype=bool)
        contact[..., layout.pairs[:, 0], layout.pairs[:, 1]] = touching
        contact[..., layout.pairs[:, 1], layout.pairs[:, 0]] = touching
        # finger contacts and their normals; `holding` (builtins.py) decides what is a grasp
        fingers = np.zeros((batch, steps, n_entities, 2), dtype=bool)
        normals = np.zeros((batch, steps, n_entities, 2, 3))
        for side, (found, normal) in enumerate(((layout.grasp_left, layout.grasp_left_normal),
                                                (layout.grasp_right, layout.grasp_right_normal))):
            touches = sensed[..., found] > 0.5
            fingers[..., layout.grasp_entities, side] = touches
            normals[..., layout.grasp_entities, side, :] = np.where(
                touches[..., None], sensed[..., normal], 0.0)
        return Frames(time=index * dt, pos=pos, quat=quat, linvel=linvel, angvel=angvel,
                      contact=contact, fingers=fingers, finger_normals=normals, opening=opening,
                      entities=self.world.entities)


def stepping_model(world: World, timestep: float | None = None) -> mujoco.MjModel:
    """The model rollouts step: the world's physics (at `timestep` if given) without sensors."""
    model = _with_timestep(world.model, world.dt if timestep is None else timestep)
    model.opt.disableflags |= NO_SENSORS
    return model


def _with_timestep(model: mujoco.MjModel, timestep: float) -> mujoco.MjModel:
    """A copy of `model` with another timestep [s]."""
    if not timestep > 0:
        raise ValueError(f"timestep must be positive, got {timestep}")
    model = copy.copy(model)
    model.opt.timestep = timestep
    return model


def _components(model: mujoco.MjModel, whole: int, part: int) -> np.ndarray:
    """Indices of the `part` state components inside a `whole` state vector."""
    positions = np.arange(mujoco.mj_stateSize(model, whole), dtype=float)
    picked = np.empty(mujoco.mj_stateSize(model, part))
    mujoco.mj_extractState(model, positions, whole, picked, part)
    return picked.astype(int)


def _record_index(nstep: int, every: int) -> np.ndarray:
    """Step indices recorded: 0, every, 2 every, ... and always nstep (the final state)."""
    index = np.arange(0, nstep + 1, every)
    if index[-1] != nstep:
        index = np.append(index, nstep)
    return index
