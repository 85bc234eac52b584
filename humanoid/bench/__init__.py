"""Benchmarks (``humanoid bench ...``): what a step costs (:mod:`.step`), what accuracy costs
in time (:mod:`.accuracy`), and the same problems in MuJoCo (:mod:`.peers`). Not imported by
``import humanoid``."""
