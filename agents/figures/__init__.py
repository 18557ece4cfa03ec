"""Every PNG the experiments and training produce: plots of reports, regions, plans and maps."""
