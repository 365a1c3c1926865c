"""The skill: segment the demonstrations, fit one arm and one gripper map per segment, place the result in a scene."""
