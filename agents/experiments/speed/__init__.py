"""Speed benchmarks (`clutter-gym bench`): the env, capture regions, planning and IK, as JSON."""
