"""The paper's experiments: plan and execute, benchmark, validate-capture, reachability, demo."""
