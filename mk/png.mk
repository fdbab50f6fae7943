# Optional PNG output/input through libpng (src/io/png.c). Default: on when pkg-config
# finds libpng. PNG=0 turns it off; PNG=1 insists and stops with one line when missing.
PNG ?=
ifneq ($(PNG),0)
  RT_PNG_FOUND := $(shell pkg-config --exists libpng 2>/dev/null && echo yes)
  ifeq ($(RT_PNG_FOUND),yes)
    FEATURE_CFLAGS += -DRT_HAVE_PNG $(shell pkg-config --cflags libpng)
    FEATURE_LIBS   += $(shell pkg-config $(if $(filter 1,$(STATIC)),--static) --libs libpng)
    FEATURES       += png
  else ifeq ($(PNG),1)
    $(error PNG=1 but pkg-config cannot find libpng: install the Debian package libpng-dev (apt-get install libpng-dev))
  endif
endif
