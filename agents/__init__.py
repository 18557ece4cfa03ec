"""The top floor: the command line, experiments, figures, learning, the job runner and policies."""
