"""Stage 4, code generation: C and NumPy kernels from the derivation.

One pipeline for every model and language:

    spec.model_spec(derivation)     kernel specs: named inputs, named outputs, stages
                                    (the in-code solve of M q'' = F, solve.py) and guards;
                                    checked with readable errors (spec.check_kernel)
    emit.cse_file(spec)             one CSE pass (SymEngine's, else sympy.cse) over all
                                    outputs of a file, split back into kernels
    backends.backends()             one backend object per target language, each in a
                                    folder of its own (backends/c, backends/numpy):
                                    its printer (printers.py), reserved words, file
                                    suffixes, the templates/<language>/ folder it renders
                                    (Jinja2, StrictUndefined) and the artifacts it emits;
                                    discovered, not wired.  Python decides, templates lay out
    generate.generate_all(root)     writes generated/ (or, with check=True, diffs it)

loader.load(model) compiles generated/c/<model>.c into a content-keyed cache and
returns NumPy-callable kernels backed by the batch entry points;
reference.Reference evaluates the derivation itself with mpmath, for the tests.
"""
