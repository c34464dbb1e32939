"""Code generation: the golden generated/ tree, backends, compilers, the loader, the run contract, the kernels against the derivation."""
