# dualsig: dual finite element analysis for Signorini problems.  See README.md.
#
#   make            build lib/libdualsig.a, include/*.mod and bin/dualsig (optimised)
#   make run        install missing Debian packages, build, run data/default.nml
#   make check      install missing Debian packages, build the debug library, run the test suite
#   make check-asan the same suite under Address/UndefinedBehavior/LeakSanitizer
#   make bench      benchmarks (see README, "Benchmarks")
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
LIBS ?= -lcholmod -lsuitesparseconfig -llapack -lblas

# Debian packages the project needs (build, run and test).
DEBIAN_PACKAGES := gfortran make liblapack-dev libblas-dev libopenblas-dev libsuitesparse-dev libmetis-dev python3

BLD  := build/$(BUILD)
SRCS := $(sort $(wildcard src/*.f90))
CSRCS := $(sort $(wildcard src/*.c))
OBJS := $(patsubst src/%.f90,$(BLD)/%.o,$(SRCS)) $(patsubst src/%.c,$(BLD)/%.o,$(CSRCS))

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

.PHONY: all lib run check check-lite check-asan deps bench bench-quick bench-plots bench-peers bench-deps clean distclean
all: $(LIBRARY) $(DRIVER)
lib: $(LIBRARY)

$(sort $(BLD) $(MODDIR) $(LIBDIR) $(BINDIR)):
	@mkdir -p $@

# Module dependencies, derived from the "use" statements of src/*.f90.
$(BLD)/deps.mk: $(SRCS) Makefile | $(BLD)
	@for f in $(SRCS); do m=$$(basename $$f .f90); \
	  for u in $$(sed -n 's/^ *use *\(, *intrinsic *::\)\? *\([A-Za-z0-9_]*\).*/\2/p' $$f | sort -u); do \
	    if [ -f src/$$u.f90 ] && [ $$u != $$m ]; then echo "$(BLD)/$$m.o: $(BLD)/$$u.o"; fi; \
	  done; done > $@
-include $(BLD)/deps.mk

$(BLD)/%.o: src/%.f90 | $(BLD) $(MODDIR)
	$(FC) $(STD_FLAGS) $(FFLAGS) -J$(MODDIR) -I$(MODDIR) -c $< -o $@

# C shims (CHOLMOD); Fortran reaches them through bind(c) interfaces, a link-time dependency only.
$(BLD)/%.o: src/%.c | $(BLD)
	$(CC) -O2 -g -Wall -Wextra -I/usr/include/suitesparse -c $< -o $@

$(LIBRARY): $(OBJS) | $(LIBDIR)
	@rm -f $@
	ar rcs $@ $(OBJS)

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

ifdef PFUNIT_DIR
# Real pFUnit 4: the same .pf files through pFUnit's own preprocessor and runner.
include $(PFUNIT_DIR)/include/PFUNIT.mk
FFLAGS += $(PFUNIT_EXTRA_FFLAGS) -I$(CURDIR)/build/debug/mod
dualsig_tests_TESTS := $(notdir $(TEST_PF))
dualsig_tests_OTHER_LIBRARIES := $(CURDIR)/build/debug/libdualsig.a $(LIBS)
dualsig_tests_OTHER_INCS := -I$(CURDIR)/build/debug/mod
%.o: %.F90
	$(FC) -c $(FFLAGS) $<
check: deps
	@$(MAKE) BUILD=debug all
	@cd test && $(MAKE) -f ../Makefile PFUNIT_DIR=$(PFUNIT_DIR) dualsig_tests
	@cd test && DUALSIG_DRIVER=$(CURDIR)/build/debug/dualsig DUALSIG_ROOT=$(CURDIR) ./dualsig_tests
$(eval $(call make_pfunit_test,dualsig_tests))
else
check: deps
	@$(MAKE) BUILD=debug all
	@$(MAKE) check-lite
endif

# The fallback runner: test/pfunit_lite.py translates the .pf subset into Fortran.
# TEST_BUILD names the library build the suite links (debug, or asan for check-asan).
TEST_BUILD ?= debug
TEST_FLAGS ?= $(DEBUG_FLAGS)
check-lite:
	@mkdir -p $(TBLD)-$(TEST_BUILD)
	@python3 test/pfunit_lite.py --out-dir $(TBLD)-$(TEST_BUILD) $(TEST_PF)
	@$(FC) $(STD_FLAGS) $(TEST_FLAGS) -Wno-unused-dummy-argument -J$(TBLD)-$(TEST_BUILD) -I$(TBLD)-$(TEST_BUILD) \
	   -Ibuild/$(TEST_BUILD)/mod test/lite/funit.f90 $(patsubst test/%.pf,$(TBLD)-$(TEST_BUILD)/%.F90,$(TEST_PF)) \
	   $(TBLD)-$(TEST_BUILD)/pfunit_lite_main.F90 -o $(TBLD)-$(TEST_BUILD)/dualsig_tests \
	   build/$(TEST_BUILD)/libdualsig.a $(LIBS)
	@DUALSIG_DRIVER=$(CURDIR)/build/$(TEST_BUILD)/dualsig DUALSIG_ROOT=$(CURDIR) ./$(TBLD)-$(TEST_BUILD)/dualsig_tests

# The suite under AddressSanitizer, UndefinedBehaviorSanitizer and LeakSanitizer (with the
# run-time checks and floating-point traps of the debug build).
ASAN_FLAGS := -g -O1 -fsanitize=address,undefined -fno-omit-frame-pointer -fcheck=all \
              -ffpe-trap=invalid,zero,overflow -fbacktrace
check-asan: deps
	@$(MAKE) BUILD=asan FFLAGS="$(ASAN_FLAGS)" all
	@ASAN_OPTIONS=detect_leaks=1:abort_on_error=0 UBSAN_OPTIONS=halt_on_error=1 \
	  $(MAKE) check-lite TEST_BUILD=asan TEST_FLAGS="$(ASAN_FLAGS)"

# ---------------------------------------------------------------- benchmarks
# make bench        all tables (about 10 minutes: the largest meshes have 1e6 unknowns), plots
# make bench-quick  the small tables only (primal, dual_p1, dual_p2 sections; about 1 minute)
# make bench-peers  the same QPs solved by PETSc (python3-petsc4py), if installed
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

bench-quick: bench-deps
	@$(MAKE) all
	@$(MAKE) -s bin/dualsig_bench
	@./bin/dualsig_bench primal dual_p1 dual_p2

bench-plots:
	@if command -v gnuplot >/dev/null; then gnuplot bench/work_precision.gp && \
	  echo "dualsig: plots written to out/work_precision.png and out/scaling.png"; \
	else echo "dualsig: gnuplot not installed: no plots"; fi

# PETSc is optional: installed here when possible (python3-petsc4py: about 150 MB with MPI),
# otherwise the script prints that it is skipped.  Needs the QP exports of `make bench`.
PEER_PACKAGES := python3-petsc4py
PEER_QPS ?= out/qp_p2_contact_l8 out/qp_p1_contact_l8 out/qp_p2_contact_l10
PEER_OPTIONS ?= --time-limit 400
bench-peers:
	@if ! dpkg-query -W -f='$${Status}' $(PEER_PACKAGES) 2>/dev/null | grep -q "install ok installed"; then \
	  if [ "$$(id -u)" = 0 ]; then DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
	    $(PEER_PACKAGES) >/dev/null || true; fi; fi
	@for q in $(PEER_QPS); do [ -f $${q}_A.mtx ] || { echo "dualsig: $${q}_A.mtx missing: run make bench first"; exit 1; }; done
	@python3 bench/petsc_peers.py $(PEER_QPS) --csv out/bench_peers.csv $(PEER_OPTIONS)

bin/dualsig_bench: drivers/dualsig_bench.f90 $(LIBRARY) | bin
	$(FC) $(STD_FLAGS) $(FFLAGS) -Iinclude $< -o $@ $(LIBRARY) $(LIBS)

clean:
	rm -rf build lib include bin
distclean: clean
