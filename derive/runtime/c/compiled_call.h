/* derive's compiled call path (compiled_call.c): a CPython extension module, built at run
   time into derive's cache by derive/runtime/compiled_call.py.  Nothing to declare for
   other C: the header is the loader's companion file (its build key hashes it). */
#ifndef DERIVE_COMPILED_CALL_H
#define DERIVE_COMPILED_CALL_H
#define DERIVE_COMPILED_CALL_MAX_N 64       /* states or parameters read onto the stack */
#define DERIVE_COMPILED_CALL_INFO_MAX 2048  /* bytes of the info struct held on the stack */
#endif
