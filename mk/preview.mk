# OpenGL preview (src/preview/, docs/preview.md). The GLUT window (-gui) needs
# pkg-config's gl + glut + x11 (Debian libglut-dev brings all three), the offscreen
# snapshot (-gui_snapshot) osmesa (libosmesa6-dev): their headers at build time; the
# libraries themselves are opened at run time (dynload.c). Both go into one binary: the
# drawing code calls GL through a table of entry points (src/preview/gl_api.h), so
# libGL and libOSMesa never compete for the gl* symbols. PREVIEW=0 leaves both out,
# PREVIEW=1 insists on both. The preview's files are always compiled: without the
# libraries they hold the "not built" answers of include/rt/preview.h.
PREVIEW ?=
RT_PV_GLUT :=
RT_PV_OSMESA :=
ifeq ($(PREVIEW),0)
  FEATURE_CFLAGS += -DRT_PREVIEW_LEFT_OUT
else
  RT_PV_GLUT := $(shell pkg-config --exists gl glut x11 2>/dev/null && echo yes)
  RT_PV_OSMESA := $(shell pkg-config --exists osmesa 2>/dev/null && echo yes)
  ifeq ($(PREVIEW),1)
    ifneq ($(RT_PV_GLUT)$(RT_PV_OSMESA),yesyes)
      $(error PREVIEW=1 but pkg-config cannot find GL/GLUT/OSMesa: apt-get install libglut-dev libosmesa6-dev)
    endif
  endif
endif
ifeq ($(RT_PV_GLUT),yes)
  FEATURE_CFLAGS += -DRT_HAVE_GLUT $(shell pkg-config --cflags gl glut x11)
  FEATURES       += gui
endif
ifeq ($(RT_PV_OSMESA),yes)
  FEATURE_CFLAGS += -DRT_HAVE_OSMESA $(shell pkg-config --cflags osmesa)
  FEATURES       += osmesa
endif
# The libraries are not linked: src/preview/dynload.c opens them when -gui or
# -gui_snapshot asks (linked, they would add ~19 ms to every start of the program).
ifneq ($(RT_PV_GLUT)$(RT_PV_OSMESA),)
  FEATURE_LIBS += -ldl
endif
EXTRA_SRCS += $(sort $(wildcard src/preview/*.c))
