/* The OpenGL 1.1 entry points the preview uses, as a table of function pointers. Why a
 * table: libGL (glvnd, for the GLUT window) and libOSMesa both export gl* symbols, and
 * a direct call binds to whichever library the linker saw first; through the table the
 * window calls libGL's entries and the snapshot calls OSMesa's own, in one binary. */
#ifndef RT_PREVIEW_GL_API_H
#define RT_PREVIEW_GL_API_H

#include <stdbool.h>
#include <GL/gl.h>

/* X(return type, name without "gl", parameter list) */
#define RT_GL_FUNCS(X) \
    X(void, Begin, (GLenum mode)) \
    X(void, End, (void)) \
    X(void, Vertex3f, (GLfloat x, GLfloat y, GLfloat z)) \
    X(void, Normal3f, (GLfloat x, GLfloat y, GLfloat z)) \
    X(void, Color3f, (GLfloat r, GLfloat g, GLfloat b)) \
    X(void, Color4f, (GLfloat r, GLfloat g, GLfloat b, GLfloat a)) \
    X(void, Materialfv, (GLenum face, GLenum pname, const GLfloat *params)) \
    X(void, Materialf, (GLenum face, GLenum pname, GLfloat param)) \
    X(void, Lightfv, (GLenum light, GLenum pname, const GLfloat *params)) \
    X(void, Lightf, (GLenum light, GLenum pname, GLfloat param)) \
    X(void, LightModelfv, (GLenum pname, const GLfloat *params)) \
    X(void, LightModeli, (GLenum pname, GLint param)) \
    X(void, Enable, (GLenum cap)) \
    X(void, Disable, (GLenum cap)) \
    X(void, MatrixMode, (GLenum mode)) \
    X(void, LoadIdentity, (void)) \
    X(void, LoadMatrixf, (const GLfloat *m)) \
    X(void, MultMatrixf, (const GLfloat *m)) \
    X(void, PushMatrix, (void)) \
    X(void, PopMatrix, (void)) \
    X(void, Ortho, (GLdouble l, GLdouble r, GLdouble b, GLdouble t, GLdouble n, GLdouble f)) \
    X(void, Frustum, (GLdouble l, GLdouble r, GLdouble b, GLdouble t, GLdouble n, GLdouble f)) \
    X(void, Viewport, (GLint x, GLint y, GLsizei w, GLsizei h)) \
    X(void, ClearColor, (GLclampf r, GLclampf g, GLclampf b, GLclampf a)) \
    X(void, Clear, (GLbitfield mask)) \
    X(void, LineWidth, (GLfloat w)) \
    X(void, BlendFunc, (GLenum s, GLenum d)) \
    X(void, DepthMask, (GLboolean flag)) \
    X(void, ShadeModel, (GLenum mode)) \
    X(void, PolygonOffset, (GLfloat factor, GLfloat units)) \
    X(void, RasterPos2f, (GLfloat x, GLfloat y)) \
    X(void, DrawPixels, (GLsizei w, GLsizei h, GLenum format, GLenum type, const GLvoid *p)) \
    X(void, ReadPixels, (GLint x, GLint y, GLsizei w, GLsizei h, GLenum format, GLenum type, \
                         GLvoid *p)) \
    X(void, ReadBuffer, (GLenum mode)) \
    X(void, PixelStorei, (GLenum pname, GLint param)) \
    X(void, Finish, (void)) \
    X(void, GetIntegerv, (GLenum pname, GLint *params)) \
    X(GLenum, GetError, (void))

#define RT_GL_MEMBER(ret, name, params) ret (APIENTRY *name) params;
typedef struct GlApi {
    RT_GL_FUNCS(RT_GL_MEMBER)
} GlApi;
#undef RT_GL_MEMBER

/* Fills every entry through getproc("glBegin", ...). False (naming the first missing
 * function in *missing) when one is not found. void (*)(void) is the generic function
 * pointer type of GLX/OSMesa GetProcAddress. */
typedef void (*GlProc)(void);
typedef GlProc (*GlGetProc)(const char *name);
bool gl_api_load(GlApi *gl, GlGetProc getproc, const char **missing);

#endif
