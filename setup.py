"""The compiled kernels (humanoid/kernels.c: the Python C API only, no NumPy headers); the
rest of the package's metadata is in pyproject.toml."""

from setuptools import Extension, setup

setup(
    ext_modules=[
        Extension(
            "humanoid.kernels",
            ["humanoid/kernels.c"],
            # the same rounding as the NumPy path: no fused multiply-adds
            extra_compile_args=["-O3", "-std=c99", "-ffp-contract=off"],
        )
    ]
)
