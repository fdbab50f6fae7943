/* Loading the GL entry-point table (gl_api.h) through a GetProcAddress function. */
#if defined(RT_HAVE_GLUT) || defined(RT_HAVE_OSMESA)
#include "gl_api.h"

/* Mesa and LLVM keep a few allocations until process exit; under LeakSanitizer (make
 * asan) those are not ours. Only stacks through these libraries are suppressed. */
const char *__lsan_default_suppressions(void);
const char *__lsan_default_suppressions(void)
{
    return "leak:libOSMesa.so\nleak:libLLVM\nleak:libGLX_mesa.so\nleak:libglut.so\n"
           "leak:libX11.so\nleak:libgallium\nleak:libglapi.so\nleak:libGLdispatch.so\n"
           "leak:swrast_dri.so\nleak:libdrm\n";
}

bool gl_api_load(GlApi *gl, GlGetProc getproc, const char **missing)
{
#define RT_GL_LOAD(ret, name, params) \
    gl->name = (ret (APIENTRY *) params)getproc("gl" #name); \
    if (!gl->name) { \
        *missing = "gl" #name; \
        return false; \
    }
    RT_GL_FUNCS(RT_GL_LOAD)
#undef RT_GL_LOAD
    return true;
}
#else
typedef int rt_preview_gl_api_unused; /* keeps the translation unit non-empty */
#endif
