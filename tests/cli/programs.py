"""Small programs the command-line tests share."""

CLEAN = """\
primitive reach_it {
  goal "Touch the target"
  roles { target: Object, hand: Manipulator }
  success { touching(hand, target) }
  cost final = distance(hand, target) / 1cm
  motion { keypoint reach = pos(target) }
}
"""

# One type error on line 5: adding a Length and an Angle.
BAD = CLEAN.replace("distance(hand, target) / 1cm", "(distance(hand, target) + 10deg) / 1cm")

# Checks clean, but `table` is never used (lint warning W0101).
WARNS = CLEAN.replace("hand: Manipulator }", "hand: Manipulator, table: Surface }")
