/* Run-time loading of the preview's libraries. Linked the ordinary way, libGL, GLUT and
 * above all libOSMesa (which brings in LLVM) cost ~19 ms at every start of the program,
 * also for renders that never open a window (1 ms without them). So the preview's
 * GLUT, X11, GLX and OSMesa entry points are looked up with dlopen/dlsym when -gui or
 * -gui_snapshot asks for them, and the call sites keep their usual names through the
 * macros below (include this header after the libraries' own headers). */
#ifndef RT_PREVIEW_DYNLOAD_H
#define RT_PREVIEW_DYNLOAD_H

#include <stdbool.h>
#include "rt/diag.h"

#ifdef RT_HAVE_GLUT
#include <GL/freeglut.h>
#include <GL/glx.h>
#include <X11/Xlib.h>

#define RT_GLUT_FUNCS(X) \
    X(glutInit) X(glutInitDisplayMode) X(glutInitWindowSize) X(glutInitWindowPosition) \
    X(glutCreateWindow) X(glutDestroyWindow) X(glutDisplayFunc) X(glutReshapeFunc) \
    X(glutKeyboardFunc) X(glutMouseFunc) X(glutMotionFunc) X(glutPassiveMotionFunc) \
    X(glutTimerFunc) X(glutPostRedisplay) X(glutSwapBuffers) X(glutSetWindow) \
    X(glutSetOption) X(glutMainLoop) X(glutLeaveMainLoop) X(glutGetProcAddress) \
    X(glutCloseFunc)
#define RT_X11_FUNCS(X) X(XOpenDisplay) X(XCloseDisplay) X(XSelectInput) \
    X(XCheckTypedWindowEvent) X(XFlush) X(XSetErrorHandler)
#define RT_GLX_FUNCS(X) X(glXQueryExtension) X(glXGetCurrentDrawable)

#define RT_DECLARE_FN(f) __typeof__(f) *f;
typedef struct PreviewWindowApi {
    RT_GLUT_FUNCS(RT_DECLARE_FN)
    RT_X11_FUNCS(RT_DECLARE_FN)
    RT_GLX_FUNCS(RT_DECLARE_FN)
} PreviewWindowApi;
extern PreviewWindowApi preview_window_api;

/* Loads libglut, libX11 and libGL once; false (and a message naming the Debian
 * packages) when one is missing. */
bool preview_load_window_libs(Diag *diag);
#endif

#ifdef RT_HAVE_OSMESA
#include <GL/osmesa.h>

#define RT_OSMESA_FUNCS(X) \
    X(OSMesaCreateContextExt) X(OSMesaMakeCurrent) X(OSMesaDestroyContext) \
    X(OSMesaGetProcAddress)
typedef struct PreviewOsmesaApi {
    RT_OSMESA_FUNCS(RT_DECLARE_FN)
} PreviewOsmesaApi;
extern PreviewOsmesaApi preview_osmesa_api;

bool preview_load_osmesa_libs(Diag *diag);
#endif

/* From here on the names call through the loaded pointers. A macro is not expanded
 * again inside its own expansion, so the member names stay plain. dynload.c itself,
 * which fills the pointers, defines RT_DYNLOAD_IMPL to keep the real names. */
#ifndef RT_DYNLOAD_IMPL
#ifdef RT_HAVE_GLUT
#define glutInit (preview_window_api.glutInit)
#define glutInitDisplayMode (preview_window_api.glutInitDisplayMode)
#define glutInitWindowSize (preview_window_api.glutInitWindowSize)
#define glutInitWindowPosition (preview_window_api.glutInitWindowPosition)
#define glutCreateWindow (preview_window_api.glutCreateWindow)
#define glutDestroyWindow (preview_window_api.glutDestroyWindow)
#define glutDisplayFunc (preview_window_api.glutDisplayFunc)
#define glutReshapeFunc (preview_window_api.glutReshapeFunc)
#define glutKeyboardFunc (preview_window_api.glutKeyboardFunc)
#define glutMouseFunc (preview_window_api.glutMouseFunc)
#define glutMotionFunc (preview_window_api.glutMotionFunc)
#define glutPassiveMotionFunc (preview_window_api.glutPassiveMotionFunc)
#define glutTimerFunc (preview_window_api.glutTimerFunc)
#define glutPostRedisplay (preview_window_api.glutPostRedisplay)
#define glutSwapBuffers (preview_window_api.glutSwapBuffers)
#define glutSetWindow (preview_window_api.glutSetWindow)
#define glutSetOption (preview_window_api.glutSetOption)
#define glutMainLoop (preview_window_api.glutMainLoop)
#define glutLeaveMainLoop (preview_window_api.glutLeaveMainLoop)
#define glutGetProcAddress (preview_window_api.glutGetProcAddress)
#define glutCloseFunc (preview_window_api.glutCloseFunc)
#define XOpenDisplay (preview_window_api.XOpenDisplay)
#define XCloseDisplay (preview_window_api.XCloseDisplay)
#define XSelectInput (preview_window_api.XSelectInput)
#define XCheckTypedWindowEvent (preview_window_api.XCheckTypedWindowEvent)
#define XFlush (preview_window_api.XFlush)
#define XSetErrorHandler (preview_window_api.XSetErrorHandler)
#define glXQueryExtension (preview_window_api.glXQueryExtension)
#define glXGetCurrentDrawable (preview_window_api.glXGetCurrentDrawable)
#endif
#ifdef RT_HAVE_OSMESA
#define OSMesaCreateContextExt (preview_osmesa_api.OSMesaCreateContextExt)
#define OSMesaMakeCurrent (preview_osmesa_api.OSMesaMakeCurrent)
#define OSMesaDestroyContext (preview_osmesa_api.OSMesaDestroyContext)
#define OSMesaGetProcAddress (preview_osmesa_api.OSMesaGetProcAddress)
#endif
#endif /* RT_DYNLOAD_IMPL */

#endif
