# `make mpi`: ./raytracer-mpi, the same main linked with src/dist/dist_mpi.c and
# OpenMPI (Debian: libopenmpi-dev openmpi-bin). Only built when asked for, so the
# default build and CI without MPI never need it. MPICC names the wrapper compiler.
MPICC   ?= mpicc
# Beside ./raytracer for the default build folder, inside any other (like BIN).
MPI_BIN := $(if $(filter build,$(BUILD)),raytracer-mpi,$(BUILD)/raytracer-mpi)
MPI_OBJ := $(BUILD)/mpi/dist_mpi.o

.PHONY: mpi
mpi: $(MPI_BIN) all

$(MPI_OBJ): src/dist/dist_mpi.c $(BUILD)/flags
	@command -v $(MPICC) >/dev/null 2>&1 || { echo "make mpi: $(MPICC) not found: install the Debian packages libopenmpi-dev openmpi-bin (apt-get install libopenmpi-dev openmpi-bin)"; exit 1; }
	@mkdir -p $(dir $@)
	$(say) MPICC $<
	$(Q)$(MPICC) $(ALL_CFLAGS) -c -o $@ $<

# (main.o and librt.a by name: this file is read before the Makefile defines them)
$(MPI_BIN): $(BUILD)/src/main.o $(MPI_OBJ) $(BUILD)/librt.a $(BUILD)/flags
	$(say) LINK $@
	$(Q)$(MPICC) -o $@ $(filter-out $(BUILD)/flags,$^) $(LDLIBS_ALL)

# Once built, `make test` keeps it up to date and tests it (tests/e2e/test_mpi.c).
test: $(if $(wildcard $(MPI_BIN)),$(MPI_BIN))

-include $(MPI_OBJ:.o=.d)
