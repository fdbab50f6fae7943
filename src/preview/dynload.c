/* dlopen/dlsym of the preview's libraries, on first use (see dynload.h for why). */
#include <dlfcn.h>
#include <pthread.h>
#include <string.h>

#if defined(RT_HAVE_GLUT) || defined(RT_HAVE_OSMESA)
#define RT_DYNLOAD_IMPL
#include "dynload.h"

/* Opens the first of names that loads; NULL and the last dlerror() otherwise. */
static void *open_any(const char *const *names, const char **err)
{
    for (int i = 0; names[i]; i++) {
        void *h = dlopen(names[i], RTLD_NOW | RTLD_GLOBAL);
        if (h)
            return h;
        *err = dlerror();
    }
    return NULL;
}

/* Resolves one symbol from any of the handles (object pointer -> function pointer
 * through memcpy: ISO C has no cast between them, POSIX guarantees the sizes match). */
static bool resolve(void *const *handles, int n, const char *name, void *slot, size_t size,
                    const char **missing)
{
    for (int i = 0; i < n; i++) {
        void *p = handles[i] ? dlsym(handles[i], name) : NULL;
        if (p) {
            memcpy(slot, &p, size);
            return true;
        }
    }
    *missing = name;
    return false;
}
#endif

#ifdef RT_HAVE_GLUT
PreviewWindowApi preview_window_api;

bool preview_load_window_libs(Diag *diag)
{
    static bool loaded;
    if (loaded)
        return true;
    static const char *const glut[] = {"libglut.so.3.12", "libglut.so.3", "libglut.so", NULL};
    static const char *const x11[] = {"libX11.so.6", "libX11.so", NULL};
    static const char *const gl[] = {"libGL.so.1", "libGL.so", NULL};
    const char *err = "unknown error";
    void *h[3] = {open_any(glut, &err), open_any(x11, &err), open_any(gl, &err)};
    if (!h[0] || !h[1] || !h[2]) {
        diag_error(diag, NULL, "-gui: cannot load the window libraries (%s); "
                   "apt-get install libglut3.12 libx11-6 libgl1", err);
        return false;
    }
    const char *missing = NULL;
    bool ok = true;
#define RT_RESOLVE(f) \
    ok = ok && resolve(h, 3, #f, &preview_window_api.f, sizeof preview_window_api.f, &missing);
    RT_GLUT_FUNCS(RT_RESOLVE)
    RT_X11_FUNCS(RT_RESOLVE)
    RT_GLX_FUNCS(RT_RESOLVE)
#undef RT_RESOLVE
    if (!ok) {
        diag_error(diag, NULL, "-gui: the window libraries lack %s", missing);
        return false;
    }
    loaded = true;
    return true;
}
#endif

#ifdef RT_HAVE_OSMESA
PreviewOsmesaApi preview_osmesa_api;

bool preview_load_osmesa_libs(Diag *diag)
{
    static bool loaded;
    if (loaded)
        return true;
    static const char *const osmesa[] = {"libOSMesa.so.8", "libOSMesa.so.6", "libOSMesa.so",
                                         NULL};
    const char *err = "unknown error";
    void *h[1] = {open_any(osmesa, &err)};
    if (!h[0]) {
        diag_error(diag, NULL, "-gui_snapshot: cannot load OSMesa (%s); apt-get install libosmesa6",
                   err);
        return false;
    }
    const char *missing = NULL;
    bool ok = true;
#define RT_RESOLVE(f) \
    ok = ok && resolve(h, 1, #f, &preview_osmesa_api.f, sizeof preview_osmesa_api.f, &missing);
    RT_OSMESA_FUNCS(RT_RESOLVE)
#undef RT_RESOLVE
    if (!ok) {
        diag_error(diag, NULL, "-gui_snapshot: OSMesa lacks %s", missing);
        return false;
    }
    loaded = true;
    return true;
}
#endif
