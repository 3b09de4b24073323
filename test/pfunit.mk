# The test suite under a genuine pFUnit 4 install: the sub-make of `make check PFUNIT_DIR=...`.
# It runs inside the build directory (build/test-pfunit), so that every product -- the .F90
# files written by funitproc, objects, module files, the registry dualsig_tests.inc and the
# program dualsig_tests -- lands there and nothing is written into test/.  The top Makefile
# passes everything as absolute paths:
#
#   make -C build/test-pfunit -f $(ROOT)/test/pfunit.mk ROOT=<source tree> PFUNIT_DIR=<install> \
#        TEST_PF='<absolute paths of the .pf files>' TEST_FFLAGS='<compiler flags>' LIBS='...'
#
# The library and its module files are those of the debug build: $(ROOT)/build/debug.
ifndef ROOT
$(error ROOT (the source tree, absolute) is not set: run this through "make check PFUNIT_DIR=...")
endif
ifndef PFUNIT_DIR
$(error PFUNIT_DIR is not set)
endif
ifeq ($(strip $(TEST_PF)),)
$(error TEST_PF (the .pf files) is empty)
endif

ifeq ($(origin FC),default)
FC := gfortran
endif
include $(PFUNIT_DIR)/include/PFUNIT.mk

# funitproc reads NAME.pf from the source directory and writes NAME.F90 here.
vpath %.pf $(sort $(dir $(TEST_PF)))

# Set before make_pfunit_test: its driver rule expands $(FFLAGS) when the macro is evaluated.
FFLAGS := $(TEST_FFLAGS) $(PFUNIT_EXTRA_FFLAGS) -I$(ROOT)/build/debug/support-mod -I$(ROOT)/build/debug/mod
dualsig_tests_TESTS := $(notdir $(TEST_PF))
dualsig_tests_OTHER_LIBRARIES := $(ROOT)/build/debug/libdualsig_support.a $(ROOT)/build/debug/libdualsig.a $(LIBS)

# pFUnit's macro has no rule to compile the generated sources.
%.o: %.F90
	$(FC) -c $(FFLAGS) $< -o $@

# The registry dualsig_tests.inc (one ADD_TEST_SUITE line per .pf file) has no prerequisite in
# PFUNIT.mk, so a registry from an earlier, different list of tests would survive.  It depends
# here on dualsig_tests.list, the list of test files, rewritten only when the list changes.
dualsig_tests.list: FORCE
	@echo '$(dualsig_tests_TESTS)' | cmp -s - $@ || echo '$(dualsig_tests_TESTS)' > $@
dualsig_tests.inc: dualsig_tests.list

# Every object is rebuilt when the library's module files may have changed.
$(dualsig_tests_TESTS:.pf=.o): $(ROOT)/build/debug/libdualsig.a

.PHONY: FORCE
FORCE:

$(eval $(call make_pfunit_test,dualsig_tests))
