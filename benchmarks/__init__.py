"""evodevo's benchmark suite: each module measures a ratio in one run (``run(quick) -> dict``)."""
