# Optional PNG output/input through libpng (src/io/png.c). Default: on when pkg-config
# finds libpng. PNG=0 turns it off; PNG=1 insists and stops with one line when missing.
PNG ?=
# What PNG=0 adds: src/io/png.c then says PNG was left out on purpose, not that libpng
# is missing. A variable, so tests/unit/test_png_left_out.c is compiled with the same.
PNG_LEFT_OUT_CFLAGS := -DRT_PNG_LEFT_OUT
ifeq ($(PNG),0)
  FEATURE_CFLAGS += $(PNG_LEFT_OUT_CFLAGS)
endif
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

# tests/unit/test_png_left_out.c compiles src/io/png.c as a PNG=0 build does (without
# libpng, with PNG=0's flags), whatever this build is: its message is checked without
# building a whole PNG=0 variant.
$(BUILD)/tests/unit/test_png_left_out.o: ALL_CFLAGS += -URT_HAVE_PNG $(PNG_LEFT_OUT_CFLAGS)
$(BUILD)/tests/unit/test_png_left_out.o: src/io/png.c
