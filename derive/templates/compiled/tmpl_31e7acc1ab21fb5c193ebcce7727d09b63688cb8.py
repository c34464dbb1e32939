from jinja2.runtime import LoopContext, Macro, Markup, Namespace, TemplateNotFound, TemplateReference, TemplateRuntimeError, Undefined, escape, identity, internalcode, markup_join, missing, str_join
name = 'c/vector_math.jinja'

def root(context, missing=missing):
    resolve = context.resolve_or_missing
    undefined = environment.undefined
    concat = environment.concat
    cond_expr_undefined = Undefined
    if 0: yield None
    l_0_prelude = l_0_lanes = missing
    try:
        t_1 = environment.filters['join']
    except KeyError:
        @internalcode
        def t_1(*unused):
            raise TemplateRuntimeError("No filter named 'join' found.")
    pass
    def macro(l_1_M, l_1_functions):
        t_2 = []
        if l_1_M is missing:
            l_1_M = undefined("parameter 'M' was not provided", name='M')
        if l_1_functions is missing:
            l_1_functions = undefined("parameter 'functions' was not provided", name='functions')
        pass
        t_2.extend((
            "#if defined(DERIVE_VECTOR_MATH) && defined(__GLIBC__) && defined(__x86_64__)\n/* glibc's libmvec has vector variants of ",
            str(t_1(context.eval_ctx, l_1_functions, ' and ')),
            '; declaring them `omp declare simd`\n * (what <math.h> does only under -ffast-math) lets the compiler call them in the loops\n * marked ',
            str(l_1_M),
            '_SIMD.  Built without -DDERIVE_VECTOR_MATH, those loops are plain C.\n * GCC flags: -DDERIVE_VECTOR_MATH -fpeel-loops -fopenmp-simd',
        ))
        for l_2_f in l_1_functions:
            _loop_vars = {}
            pass
            t_2.extend((
                ' -fno-builtin-',
                str(l_2_f),
            ))
        l_2_f = missing
        t_2.append(
            ' -lmvec\n * (derive.runtime.loader.VECTOR_MATH_FLAGS). */\n',
        )
        for l_2_f in l_1_functions:
            _loop_vars = {}
            pass
            t_2.extend((
                '#pragma omp declare simd notinbranch\nextern double ',
                str(l_2_f),
                '(double);\n',
            ))
        l_2_f = missing
        t_2.extend((
            '#endif\n\n/* GCC only: clang maps no libm call to libmvec here and warns about each loop it then\n * leaves scalar (-Wpass-failed). */\n#if defined(DERIVE_VECTOR_MATH) && defined(__GNUC__) && !defined(__clang__)\n#define ',
            str(l_1_M),
            '_SIMD _Pragma("omp simd")\n#else\n#define ',
            str(l_1_M),
            '_SIMD\n#endif\n',
        ))
        return concat(t_2)
    context.exported_vars.add('prelude')
    context.vars['prelude'] = l_0_prelude = Macro(environment, macro, 'prelude', ('M', 'functions'), False, False, False, context.eval_ctx.autoescape)
    def macro(l_1_t, l_1_M, l_1_indent):
        t_3 = []
        if l_1_t is missing:
            l_1_t = undefined("parameter 't' was not provided", name='t')
        if l_1_M is missing:
            l_1_M = undefined("parameter 'M' was not provided", name='M')
        if l_1_indent is missing:
            l_1_indent = undefined("parameter 'indent' was not provided", name='indent')
        pass
        t_3.extend((
            str(l_1_indent),
            'const double lane_angle[',
            str(environment.getattr(l_1_t, 'n')),
            '] = { ',
            str(environment.getattr(l_1_t, 'angles')),
            ' };\n',
            str(l_1_indent),
            'double ',
            str(environment.getattr(l_1_t, 'arrays')),
            ';\n',
            str(l_1_indent),
            'int lane;\n',
            str(l_1_indent),
            str(l_1_M),
            '_SIMD\n',
            str(l_1_indent),
            'for (lane = 0; lane < ',
            str(environment.getattr(l_1_t, 'n')),
            '; ++lane) {\n',
        ))
        if environment.getattr(l_1_t, 'sin'):
            pass
            t_3.extend((
                str(l_1_indent),
                '    lane_sin[lane] = sin(lane_angle[lane]);\n',
            ))
        if environment.getattr(l_1_t, 'cos'):
            pass
            t_3.extend((
                str(l_1_indent),
                '    lane_cos[lane] = cos(lane_angle[lane]);\n',
            ))
        t_3.extend((
            str(l_1_indent),
            '}\n',
        ))
        for l_2_v in environment.getitem(l_1_t, 'values'):
            _loop_vars = {}
            pass
            t_3.extend((
                str(l_1_indent),
                'const double ',
                str(environment.getattr(l_2_v, 'name')),
                ' = lane_',
                str(environment.getattr(l_2_v, 'kind')),
                '[',
                str(environment.getattr(l_2_v, 'lane')),
                '];\n',
            ))
        l_2_v = missing
        return concat(t_3)
    context.exported_vars.add('lanes')
    context.vars['lanes'] = l_0_lanes = Macro(environment, macro, 'lanes', ('t', 'M', 'indent'), False, False, False, context.eval_ctx.autoescape)

blocks = {}
debug_info = '2=18&4=27&6=29&7=32&9=43&11=48&18=54&20=56&27=62&28=72&29=78&30=82&31=84&32=87&33=92&34=95&36=98&37=101&39=105&40=108&41=112'