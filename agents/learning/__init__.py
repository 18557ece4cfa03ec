"""Learning on the env: the primitive env, training, evaluation, RL configs and run directories."""
