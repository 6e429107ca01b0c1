"""The numpy formulations the compiled kernels replaced: the tests' oracles, not run by the package."""
