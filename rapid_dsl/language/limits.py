"""The budget maxima of a program: one table for the checker (E0410-E0413), the command line
(`rapidc run --samples/--iterations`, a usage error above them) and docs/language.md ("Limits").

Why these numbers. One CEM iteration simulates `samples` rollouts of a phase's whole motion at
once, and the simulator keeps every state of every rollout (`simulate.py`, the `states` buffer:
samples x physics steps x state size float64). A motion lasts its `duration`, plus a 0.4 s dwell
at every keypoint that changes the grip, plus 0.5 s to settle; the rollouts step at 4 ms. At the
maxima below that is at most 10 + 16 x 0.4 + 0.5 = 16.9 s = 4,225 steps, so the buffer of a
one-object scene (32 state numbers, franka) holds 1024 x 4,225 x 32 x 8 B = 1.1 GB, and one
iteration is 4.3 M physics steps, about 30 s at the 150 k steps/s of a 2-core laptop
(docs/physics.md). Iterations add time, not memory. The standard library stays far below: at
most 48 samples, 5 iterations, 3 s and 5 keypoints.

The state grows with the scene (823 numbers for 62 boxes), and so do the sensors and the contact
matrix recorded with it, so the maxima alone do not bound memory: runtime/memory.py estimates a
whole run (4.3 GB for one object at the maxima, 82 GB for 62) and a run above MAX_RUN_BYTES is
refused before it simulates anything.

Imports nothing: the front end reads this table (the runtime never imports the front end).
"""

from __future__ import annotations

MAX_SAMPLES = 1024          # CEM population per iteration
MAX_ELITES = MAX_SAMPLES    # elites are some of the samples (E0407 says elites <= samples)
MAX_ITERATIONS = 100        # CEM iterations per phase
MAX_DURATION = 10.0         # s, `motion { duration }`; a longer task is several phases
MAX_KEYPOINTS = 16          # per primitive's motion
MAX_SPREAD = 0.5            # m, `motion { spread }`: the CEM's first std, well past any reach
MAX_SPREAD_ANGLE = 3.141592653589793   # rad, `motion { spread_angle }`: half a turn
MAX_SEED = 2**31 - 1        # `optimize { seed }`
MAX_RETRY = 5               # `phase ... retry N`: each attempt is a whole phase's CEM
MIN_PLANNING_DT = 0.0005     # s, `--planning-dt`: a quarter of the world's step (40 per tick)
MAX_EXPONENT = 1024         # |n| in `x ^ n`; the loader refuses larger ones (runtime/allow_list.py)
# Binding (runtime/binding.py) is a backtracking search, exponential in the roles a relation
# spans; it stops with exit 2 past either count. A step (a partial binding tried, or a candidate
# tuple listed to explain a rejection) costs about 2.5 us, an evaluation of a relation on new
# entities 0.5-250 us (`touching` reads a contact, `on` and `distance` rotate boxes), so either
# limit is a few seconds at most. A 64-object scene's pair relation needs 64 x 63 = 4,032.
MAX_BINDING_STEPS = 500_000
MAX_BINDING_EVALUATIONS = 10_000
MAX_RUN_BYTES = 8 * 10**9   # estimated peak memory of one run (runtime/memory.py); verify's
                            # parallel jobs count together
WORKSPACE = 10.0                   # m: every coordinate and floor_height within +-10 m
