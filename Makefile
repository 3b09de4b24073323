# dualsig: dual finite element analysis for Signorini problems.  See README.md.
#
#   make            build lib/libdualsig.a, include/*.mod and bin/dualsig (optimised)
#   make run        install missing Debian packages, build, run data/default.nml
#   make check      install missing Debian packages, build the debug library, run the test suite
#   make check-asan the same suite under Address/UndefinedBehavior/LeakSanitizer
#   make bench      benchmarks (see doc/performance.md); make bench-vtu: .vtu sizes, ascii vs binary
#   make plots      plots under out/ (make plots CSV=out/run.csv: one's own run); make doc-figures
#   make stress     the numerical stability stress suite (see doc/stress.md)
#   make fuzz       10^4 mutated inputs through bin/dualsig (see doc/testing.md, Fuzzing)
#   make BUILD=debug        the checked build (-fcheck=all, FPE traps) into build/debug
#   make FFLAGS='...'       override the compiler flags
#   make check PFUNIT_DIR=/path/to/pfunit/installed/PFUNIT-4.x   run the suite with real pFUnit
SHELL := /bin/bash
.DEFAULT_GOAL := all
MAKEFLAGS += --no-print-directory

ifeq ($(origin FC),default)
FC := gfortran
endif
ifeq ($(origin CC),default)
CC := gcc
endif
BUILD ?= release

STD_FLAGS   := -std=f2018 -fimplicit-none -ffree-line-length-132
OPT_FLAGS   := -O2 -funroll-loops
DEBUG_FLAGS := -g -O0 -fcheck=all -Wall -Wextra -Wno-compare-reals -Wno-maybe-uninitialized \
               -ffpe-trap=invalid,zero,overflow -fbacktrace
ifeq ($(origin FFLAGS),undefined)
  ifeq ($(BUILD),debug)
    FFLAGS := $(DEBUG_FLAGS)
  else
    FFLAGS := $(OPT_FLAGS)
  endif
endif
LIBS ?= -lcholmod -lsuitesparseconfig -llapack -lblas -lz

# Debian packages the project needs (build, run and test).  zlib1g-dev: zlib's compress2 for
# the compressed binary .vtu files (-lz).  python3-meshio (0.4 MB with its dependencies) lets
# test/check_vtu.py read the ParaView files with a real VTK reader.
DEBIAN_PACKAGES := gfortran make liblapack-dev libblas-dev libopenblas-dev libsuitesparse-dev libmetis-dev python3 pkg-config \
                   zlib1g-dev python3-meshio

BLD  := build/$(BUILD)
# The source tree by layer, lowest first: a module may use modules of its own layer and of
# the layers before it, never of a later one (make check-layers; src/README.md).
LAYERS := base mesh linalg qp fem problems estimates io api
SRCS := $(foreach l,$(LAYERS),$(sort $(wildcard src/$(l)/*.f90)))
CSRCS := $(foreach l,$(LAYERS),$(sort $(wildcard src/$(l)/*.c)))
OBJS := $(patsubst %.f90,$(BLD)/%.o,$(notdir $(SRCS))) $(patsubst %.c,$(BLD)/%.o,$(notdir $(CSRCS)))
vpath %.f90 $(addprefix src/,$(LAYERS))
vpath %.c $(addprefix src/,$(LAYERS))

ifeq ($(BUILD),release)
  LIBDIR := lib
  MODDIR := include
  BINDIR := bin
else
  LIBDIR := $(BLD)
  MODDIR := $(BLD)/mod
  BINDIR := $(BLD)
endif
LIBRARY := $(LIBDIR)/libdualsig.a
DRIVER  := $(BINDIR)/dualsig

# Test and driver support code (drivers/support/: the stress problems, the distorted-mesh
# generators): not part of the library, so not in SRCS and never installed.  Built against
# the library into its own archive and module folder, linked before libdualsig.a by
# bin/dualsig_stress, bin/dualsig_bench and the test suite.  support_lib/support_mod name
# them for a given build, e.g. $(call support_lib,debug) for the test suite.
SUPPORT_SRCS := $(sort $(wildcard drivers/support/*.f90))
support_lib = build/$(1)/libdualsig_support.a
support_mod = build/$(1)/support-mod
SUPPORT_LIB    := $(call support_lib,$(BUILD))
SUPPORT_MODDIR := $(call support_mod,$(BUILD))
SUPPORT_OBJS   := $(patsubst %.f90,$(BLD)/support/%.o,$(notdir $(SUPPORT_SRCS)))
# (test/pfunit.mk links build/debug/libdualsig_support.a and reads build/debug/support-mod)

.PHONY: all lib support run check check-lite check-asan check-layers deps bench bench-quick bench-vtu bench-plots bench-peers bench-p2-stream bench-deps plots stress fuzz clean distclean
all: $(LIBRARY) $(DRIVER) $(SUPPORT_LIB)
lib: $(LIBRARY)
support: $(SUPPORT_LIB)

$(sort $(BLD) $(MODDIR) $(BINDIR)):
	@mkdir -p $@

# Module dependencies, derived from the "use" statements of src/*/*.f90 (one module per
# file, named like it).
$(BLD)/deps.mk: $(SRCS) Makefile | $(BLD)
	@for f in $(SRCS); do m=$$(basename $$f .f90); \
	  for u in $$(sed -n 's/^ *use *\(, *intrinsic *::\)\? *\([A-Za-z0-9_]*\).*/\2/p' $$f | sort -u); do \
	    if [ -n "$$(ls src/*/$$u.f90 2>/dev/null)" ] && [ $$u != $$m ]; then echo "$(BLD)/$$m.o: $(BLD)/$$u.o"; fi; \
	  done; done > $@
-include $(BLD)/deps.mk

$(BLD)/%.o: %.f90 | $(BLD) $(MODDIR)
	$(FC) $(STD_FLAGS) $(FFLAGS) -J$(MODDIR) -I$(MODDIR) -c $< -o $@

# C shims (CHOLMOD); Fortran reaches them through bind(c) interfaces, a link-time dependency only.
$(BLD)/%.o: %.c | $(BLD)
	$(CC) -O2 -g -Wall -Wextra -I/usr/include/suitesparse -c $< -o $@

# (no order-only $(LIBDIR) prerequisite: in the release build it is 'lib', the phony target)
$(LIBRARY): $(OBJS)
	@mkdir -p $(@D)
	@rm -f $@
	ar rcs $@ $(OBJS)

# The support archive: every support module needs the library's modules (built with it).
$(sort $(BLD)/support $(SUPPORT_MODDIR)):
	@mkdir -p $@

$(BLD)/support/%.o: drivers/support/%.f90 $(LIBRARY) | $(BLD)/support $(SUPPORT_MODDIR)
	$(FC) $(STD_FLAGS) $(FFLAGS) -J$(SUPPORT_MODDIR) -I$(SUPPORT_MODDIR) -I$(MODDIR) -c $< -o $@

$(SUPPORT_LIB): $(SUPPORT_OBJS)
	@rm -f $@
	ar rcs $@ $(SUPPORT_OBJS)

$(DRIVER): drivers/dualsig.f90 $(LIBRARY) | $(BINDIR)
	$(FC) $(STD_FLAGS) $(FFLAGS) -I$(MODDIR) $< -o $@ $(LIBRARY) $(LIBS)

# ---------------------------------------------------------------- set-up
# Install the Debian packages that are missing; without root print the apt-get line and fail.
deps:
	@missing=""; \
	for p in $(DEBIAN_PACKAGES); do \
	  dpkg-query -W -f='$${Status}' $$p 2>/dev/null | grep -q "install ok installed" || missing="$$missing $$p"; \
	done; \
	if [ -n "$$missing" ] && [ "$$missing" = " python3" ] && command -v python3 >/dev/null; then missing=""; fi; \
	if [ -z "$$missing" ]; then exit 0; fi; \
	echo "dualsig: missing Debian packages:$$missing"; \
	if [ "$$(id -u)" != 0 ]; then \
	  echo "dualsig: run as root:  apt-get update && apt-get install -y --no-install-recommends$$missing"; \
	  exit 1; \
	fi; \
	export DEBIAN_FRONTEND=noninteractive; \
	apt-get update -qq && apt-get install -y -qq --no-install-recommends $$missing >/dev/null || { \
	  echo "dualsig: apt-get install failed for:$$missing"; exit 1; }

run: deps
	@$(MAKE) all
	@./bin/dualsig data/default.nml

# ---------------------------------------------------------------- tests
TEST_PF   := $(sort $(wildcard test/test_*.pf))
TBLD      := build/test

# The flags of the test modules, for both runners: the checked debug build's, as the library.
TEST_BUILD ?= debug
TEST_FLAGS ?= $(DEBUG_FLAGS)
TEST_FFLAGS = $(STD_FLAGS) $(TEST_FLAGS) -Wno-unused-dummy-argument

ifdef PFUNIT_DIR
# make check PFUNIT_DIR=<pFUnit 4 install>: the same .pf files through pFUnit's own preprocessor
# and runner (sub-make test/pfunit.mk, products in build/test-pfunit), run from the source tree
# as check-lite runs them.
PFUNIT_BLD := build/test-pfunit
check: deps
	@$(MAKE) check-layers
	@$(MAKE) BUILD=debug all
	@mkdir -p $(PFUNIT_BLD)
	@$(MAKE) -C $(PFUNIT_BLD) -f $(CURDIR)/test/pfunit.mk ROOT=$(CURDIR) PFUNIT_DIR=$(abspath $(PFUNIT_DIR)) \
	   FC='$(FC)' TEST_PF='$(abspath $(TEST_PF))' TEST_FFLAGS='$(TEST_FFLAGS)' LIBS='$(LIBS)' dualsig_tests
	@scratch=$$(mktemp -d) && trap 'rm -rf "$$scratch"' EXIT && TMPDIR=$$scratch \
	  DUALSIG_DRIVER=$(CURDIR)/build/debug/dualsig DUALSIG_ROOT=$(CURDIR) ./$(PFUNIT_BLD)/dualsig_tests
else
check: deps
	@$(MAKE) check-layers
	@$(MAKE) BUILD=debug all
	@$(MAKE) check-lite
endif

# The layering of src/ (no module uses one of a later layer, every module file lies in a
# layer folder and is named like its module) and the size rule (no procedure of src/ over
# MAX_PROCEDURE_LINES lines), and that every allocation of src/ checks its status
# (tools/check_alloc.py: stat= and alloc_failed, or a '! small:' comment).  Run by CI
# through make check.
MAX_PROCEDURE_LINES := 200
check-layers:
	@python3 tools/check_layers.py --max-lines $(MAX_PROCEDURE_LINES) src $(LAYERS)
	@python3 tools/check_alloc.py src

# The fallback runner: test/pfunit_lite.py translates the .pf subset into Fortran.
# Every run of a suite gets a scratch TMPDIR of its own (tests write their files there), so
# that suites of several builds or checkouts can run at the same time.
# TEST_BUILD names the library build the suite links (debug, or asan for check-asan).
check-lite:
	@mkdir -p $(TBLD)-$(TEST_BUILD)
	@python3 test/pfunit_lite.py --out-dir $(TBLD)-$(TEST_BUILD) $(TEST_PF)
	@$(FC) $(TEST_FFLAGS) -J$(TBLD)-$(TEST_BUILD) -I$(TBLD)-$(TEST_BUILD) \
	   -I$(call support_mod,$(TEST_BUILD)) -Ibuild/$(TEST_BUILD)/mod test/lite/funit.f90 $(patsubst test/%.pf,$(TBLD)-$(TEST_BUILD)/%.F90,$(TEST_PF)) \
	   $(TBLD)-$(TEST_BUILD)/pfunit_lite_main.F90 -o $(TBLD)-$(TEST_BUILD)/dualsig_tests \
	   $(call support_lib,$(TEST_BUILD)) build/$(TEST_BUILD)/libdualsig.a $(LIBS)
	@scratch=$$(mktemp -d) && trap 'rm -rf "$$scratch"' EXIT && TMPDIR=$$scratch \
	  DUALSIG_DRIVER=$(CURDIR)/build/$(TEST_BUILD)/dualsig DUALSIG_ROOT=$(CURDIR) ./$(TBLD)-$(TEST_BUILD)/dualsig_tests

# The suite under AddressSanitizer, UndefinedBehaviorSanitizer and LeakSanitizer (with the
# run-time checks and floating-point traps of the debug build).
ASAN_FLAGS := -g -O1 -fsanitize=address,undefined -fno-omit-frame-pointer -fcheck=all \
              -ffpe-trap=invalid,zero,overflow -fbacktrace
check-asan: deps
	@$(MAKE) BUILD=asan FFLAGS="$(ASAN_FLAGS)" all
	@ASAN_OPTIONS=detect_leaks=1:abort_on_error=0:allocator_may_return_null=1 UBSAN_OPTIONS=halt_on_error=1 \
	  $(MAKE) check-lite TEST_BUILD=asan TEST_FLAGS="$(ASAN_FLAGS)"

# ---------------------------------------------------------------- fuzzing
# make fuzz   FUZZ_N mutated inputs (namelists, mesh files of every format, folded and broken
#             meshes) through the optimised bin/dualsig, FUZZ_JOBS at a time (tools/fuzz_driver.py,
#             doc/testing.md#fuzzing); reproducers of failures in $(FUZZ_OUT)/failures/;
#             exit status 1 on any crash, hang or wrong certified result.  About 15 minutes
#             for 10^4 cases with 2 jobs.
FUZZ_N ?= 10000
FUZZ_SEED ?= 18
FUZZ_JOBS ?= 2
FUZZ_OUT ?= out/fuzz
FUZZ_OPTIONS ?=
fuzz: deps
	@$(MAKE) all
	@rm -rf $(FUZZ_OUT)
	@python3 tools/fuzz_driver.py --driver $(DRIVER) --n $(FUZZ_N) --seed $(FUZZ_SEED) --jobs $(FUZZ_JOBS) \
	   --out $(FUZZ_OUT) $(FUZZ_OPTIONS)

# ---------------------------------------------------------------- benchmarks
# make bench        all tables (about 12 minutes, 10 GB: the largest meshes have 1e6 nodes), plots,
#                   then the fair PETSc comparison of make bench-peers at 10^6 (about 5 more
#                   minutes; BENCH_PEERS=0 leaves it out)
# make bench-quick  the small tables only (primal, dual_p1, dual_p2 sections; about 1 minute)
# make bench-peers  the fair PETSc comparison (python3-petsc4py, installed when root; below)
BENCH_PEERS ?= 1
BENCH_PACKAGES := gnuplot-nox
bench-deps: deps
	@if ! command -v gnuplot >/dev/null; then \
	  if [ "$$(id -u)" = 0 ]; then DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
	    $(BENCH_PACKAGES) >/dev/null || echo "dualsig: could not install $(BENCH_PACKAGES): no plots"; \
	  else echo "dualsig: for the plots run as root: apt-get install -y $(BENCH_PACKAGES)"; fi; fi

bench: bench-deps
	@$(MAKE) all
	@$(MAKE) -s bin/dualsig_bench
	@./bin/dualsig_bench
	@$(MAKE) -s bench-plots
	@if [ "$(BENCH_PEERS)" != 0 ]; then $(MAKE) -s bench-peers; fi

bench-quick: bench-deps
	@$(MAKE) all
	@$(MAKE) -s bin/dualsig_bench
	@./bin/dualsig_bench primal dual_p1 dual_p2

# make bench-vtu   size and write time of the ParaView files, ascii against binary (about a
#                  minute; bench/vtu_sizes.sh, figures in doc/user-guide.md)
bench-vtu: deps
	@$(MAKE) all
	@$(MAKE) -s bin/dualsig_vtu_bench
	@bench/vtu_sizes.sh

bin/dualsig_vtu_bench: bench/vtu_write.f90 $(LIBRARY) | bin
	$(FC) $(STD_FLAGS) $(FFLAGS) -Iinclude $< -o $@ $(LIBRARY) $(LIBS)

# make bench-p2-stream   the linear P2 (stream-function) solve on the primal's multigrid
#                        hierarchy against the linear P1 solve of the same mesh (level
#                        P2STREAM_LEVEL = 9, about 10 s; doc/performance.md, the duals section)
P2STREAM_LEVEL ?= 9
bench-p2-stream: deps
	@$(MAKE) all
	@$(MAKE) -s bin/dualsig_p2_stream_bench
	@./bin/dualsig_p2_stream_bench $(P2STREAM_LEVEL)

bin/dualsig_p2_stream_bench: bench/p2_stream_bench.f90 $(LIBRARY) | bin
	$(FC) $(STD_FLAGS) $(FFLAGS) -Iinclude $< -o $@ $(LIBRARY) $(LIBS)

bench-plots:
	@if command -v gnuplot >/dev/null; then gnuplot bench/work_precision.gp && \
	  echo "dualsig: plots written to out/work_precision.png and out/scaling.png"; \
	else echo "dualsig: gnuplot not installed: no plots"; fi

# make plots   convergence and work-precision plots of the manufactured runs (bench/plots.gp):
#              runs data/p2_square.nml and data/p1_square.nml when their CSV tables are missing,
#              writes out/convergence.png and out/work_precision_runs.png, and the adaptive plots
#              (bench/adapt.gp): runs data/adapt_lshape.nml when its final mesh is missing, writes
#              out/adapt_mesh.png and, after bench/adapt_work_precision.sh,
#              out/adapt_work_precision.png.  Writes under out/ only.
# make plots CSV=out/myrun.csv   the plots of any run's CSV table (bench/plot_run.sh):
#              out/myrun_convergence.png, _work_precision.png, _bounds.png, _timing.png
#              (several tables: CSV='out/a.csv out/b.csv').  Nothing is run.
# make doc-figures   make plots, then copy its figures into doc/ (the tracked figures of the
#              documentation; the only target that writes into doc/)
PLOT_PNGS := out/convergence.png out/work_precision_runs.png
DOC_PNGS := $(PLOT_PNGS) out/adapt_mesh.png
CSV ?=
.PHONY: doc-figures
plots: bench-deps
ifneq ($(strip $(CSV)),)
	@for c in $(CSV); do bench/plot_run.sh $$c out || exit 1; done
else
	@$(MAKE) all
	@for r in p2_square p1_square; do [ -f out/$$r.csv ] || ./$(DRIVER) data/$$r.nml || [ $$? -eq 3 ] || exit 1; done
	@[ -f out/adapt_lshape_mesh.dat ] || ./$(DRIVER) data/adapt_lshape.nml || [ $$? -eq 3 ] || exit 1
	@if command -v gnuplot >/dev/null; then gnuplot bench/plots.gp && \
	  echo "dualsig: plots written to $(PLOT_PNGS)"; \
	  gnuplot bench/adapt.gp && echo "dualsig: adaptive mesh plot out/adapt_mesh.png"; \
	else echo "dualsig: gnuplot not installed: no plots"; exit 1; fi
endif

doc-figures:
	@$(MAKE) plots CSV=
	@cp $(DOC_PNGS) doc/
	@if [ -f out/adapt_work_precision.png ]; then cp out/adapt_work_precision.png doc/; fi
	@echo "dualsig: $(DOC_PNGS) copied to doc/"

# PETSc is optional: installed here when possible (python3-petsc4py: about 150 MB with MPI),
# otherwise the script prints that it is skipped.  make bench-peers: the fair comparison of
# issue 16 item 4 in one run (doc/performance.md#petsc-peers): bin/dualsig_bench peers (the
# multigrid grid sequence to PEER_LEVEL with every level's QP exported to out/peers/, cold
# multigrid and cold schur on the finest QP), then bench/petsc_peers.py --fair on the same
# QPs (cold against cold; PETSc's own grid sequencing against dualsig's).  PEER_LEVEL=10:
# about 10 minutes on 2 cores.  The Matrix Market exports of `make bench` (out/qp_*) are
# solved by `python3 bench/petsc_peers.py BASE ...` directly.
PEER_PACKAGES := python3-petsc4py
PEER_LEVEL ?= 10
PEER_SCENE ?= p2_contact
PEER_SOLVERS ?= snes-vi-hypre,snes-vi-gamg,snes-vi-chol,tao-tron
PEER_OPTIONS ?= --time-limit 400 --mem-limit-gb 16
bench-peers: bench-deps
	@if ! dpkg-query -W -f='$${Status}' $(PEER_PACKAGES) 2>/dev/null | grep -q "install ok installed"; then \
	  if [ "$$(id -u)" = 0 ]; then DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
	    $(PEER_PACKAGES) >/dev/null || true; fi; fi
	@$(MAKE) -s all
	@$(MAKE) -s bin/dualsig_bench
	@./bin/dualsig_bench peers $(PEER_LEVEL) $(PEER_SCENE)
	@python3 bench/petsc_peers.py --fair out/peers/$(PEER_SCENE) --level $(PEER_LEVEL) \
	  --solvers $(PEER_SOLVERS) --csv out/bench_peers_fair.csv $(PEER_OPTIONS)

bin/dualsig_bench: drivers/dualsig_bench.f90 $(LIBRARY) $(SUPPORT_LIB) | bin
	$(FC) $(STD_FLAGS) $(FFLAGS) -I$(SUPPORT_MODDIR) -Iinclude $< -o $@ $(SUPPORT_LIB) $(LIBRARY) $(LIBS)

# ---------------------------------------------------------------- stress suite
# make stress   the numerical stability stress cases (see doc/stress.md), 2-5 minutes;
#               tables out/stress.txt and out/stress.md; exit status 1 if a case FAILs.
#               STRESS_OPTIONS='--max-level 9' bounds the largest mesh (default level 10, ~1e6 unknowns)
STRESS_OPTIONS ?=
stress: deps
	@$(MAKE) all
	@$(MAKE) -s bin/dualsig_stress
	@./bin/dualsig_stress $(STRESS_OPTIONS)

bin/dualsig_stress: drivers/dualsig_stress.f90 $(LIBRARY) $(SUPPORT_LIB) | bin
	$(FC) $(STD_FLAGS) $(FFLAGS) -I$(SUPPORT_MODDIR) -Iinclude $< -o $@ $(SUPPORT_LIB) $(LIBRARY) $(LIBS)

# ---------------------------------------------------------------- install
# make install [PREFIX=/usr/local] [DESTDIR=]   the release library (built first), its module
#   files and a pkg-config file; DESTDIR stages the tree (dualsig.pc still names PREFIX):
#     $(PREFIX)/lib/libdualsig.a
#     $(PREFIX)/include/dualsig/<module>.mod     (one per module of src/)
#     $(PREFIX)/lib/pkgconfig/dualsig.pc
# make uninstall [PREFIX=...] [DESTDIR=]        removes exactly these files (the list is
#   computed from src/ as for install) and include/dualsig when it is left empty.
PREFIX ?= /usr/local
DESTDIR ?=
DUALSIG_VERSION ?= 0.1.0
# module names declared in src/ ("module NAME" lines; gfortran writes name.mod in lower case)
INSTALL_MODULES = $(sort $(shell sed -n 's/^ *[Mm][Oo][Dd][Uu][Ll][Ee]  *\([A-Za-z0-9_]*\) *$$/\1/p' $(SRCS) | tr A-Z a-z))
INSTALL_LIB_DIR = $(DESTDIR)$(PREFIX)/lib
INSTALL_MOD_DIR = $(DESTDIR)$(PREFIX)/include/dualsig
INSTALL_PC_DIR  = $(DESTDIR)$(PREFIX)/lib/pkgconfig

.PHONY: install uninstall install-check-prefix
install-check-prefix:
	@case "$(PREFIX)" in /*) ;; *) echo "dualsig: PREFIX must be an absolute path, got '$(PREFIX)'"; exit 1;; esac

install: install-check-prefix
	@# the file target, not the phony 'lib' (which clashes with the directory lib/ of BUILD=release)
	@$(MAKE) BUILD=release lib/libdualsig.a
	@install -d "$(INSTALL_LIB_DIR)" "$(INSTALL_MOD_DIR)" "$(INSTALL_PC_DIR)"
	@install -m 644 lib/libdualsig.a "$(INSTALL_LIB_DIR)/libdualsig.a"
	@install -m 644 $(patsubst %,include/%.mod,$(INSTALL_MODULES)) "$(INSTALL_MOD_DIR)/"
	@printf '%s\n' 'prefix=$(PREFIX)' 'exec_prefix=$${prefix}' 'libdir=$${exec_prefix}/lib' \
	  'includedir=$${prefix}/include/dualsig' '' 'Name: dualsig' \
	  'Description: Dual finite element analysis of scalar Signorini problems (Fortran; F77 entry points DSBQP, DSSIGN)' \
	  'Version: $(DUALSIG_VERSION)' 'Cflags: -I$${includedir}' 'Libs: -L$${libdir} -ldualsig' \
	  'Libs.private: $(LIBS) -lgfortran -lm' > "$(INSTALL_PC_DIR)/dualsig.pc.part"
	@mv "$(INSTALL_PC_DIR)/dualsig.pc.part" "$(INSTALL_PC_DIR)/dualsig.pc"
	@echo "dualsig: installed into $(DESTDIR)$(PREFIX): lib/libdualsig.a, lib/pkgconfig/dualsig.pc, $(words $(INSTALL_MODULES)) module files in include/dualsig"

uninstall: install-check-prefix
	@rm -f "$(INSTALL_LIB_DIR)/libdualsig.a" "$(INSTALL_PC_DIR)/dualsig.pc" \
	  $(patsubst %,"$(INSTALL_MOD_DIR)/%.mod",$(INSTALL_MODULES))
	@echo "dualsig: removed from $(DESTDIR)$(PREFIX): lib/libdualsig.a, lib/pkgconfig/dualsig.pc, $(words $(INSTALL_MODULES)) module files in include/dualsig"
	@if [ -d "$(INSTALL_MOD_DIR)" ]; then rmdir "$(INSTALL_MOD_DIR)" 2>/dev/null || \
	  echo "dualsig: $(INSTALL_MOD_DIR) is not empty (files dualsig did not install): kept"; fi

clean:
	rm -rf build lib include bin
distclean: clean

# ---------------------------------------------------------------- Gmsh data meshes
# make meshes   regenerate data/*_v2.msh (MSH 2.2) and data/*_v4.msh (MSH 4.1) from data/*.geo
#               with gmsh (Debian package gmsh, installed here when missing and run as root)
MESH_GEOS := plate_hole graded_corner
.PHONY: meshes
meshes:
	@if ! command -v gmsh >/dev/null; then \
	  if [ "$$(id -u)" != 0 ]; then \
	    echo "dualsig: gmsh missing; run as root:  apt-get install -y --no-install-recommends gmsh"; exit 1; fi; \
	  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends gmsh >/dev/null || { \
	    echo "dualsig: apt-get install failed for: gmsh"; exit 1; }; \
	fi
	@cd data && for g in $(MESH_GEOS); do \
	  gmsh -2 -format msh22 $$g.geo -o $${g}_v2.msh.tmp >/dev/null && \
	  gmsh -2 -format msh41 $$g.geo -o $${g}_v4.msh.tmp >/dev/null || { \
	    rm -f $${g}_v2.msh.tmp $${g}_v4.msh.tmp; echo "dualsig: gmsh failed on data/$$g.geo"; exit 1; }; \
	  mv $${g}_v2.msh.tmp $${g}_v2.msh && mv $${g}_v4.msh.tmp $${g}_v4.msh; \
	  echo "dualsig: data/$${g}_v2.msh and data/$${g}_v4.msh written"; \
	done
