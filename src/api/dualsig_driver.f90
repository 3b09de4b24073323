!> Batch driver: runs every run of a namelist file through the analysis pipeline
!> (dualsig_analysis) and writes one error table per run (aligned text `<output>.txt` and
!> CSV `<output>.csv`, on request LaTeX and ParaView files).
!>
!> This module only translates: a &run configuration into an analysis problem (mesh
!> from a generator or a file, boundary parts, the scene's load and exact solution) and
!> settings, and each level's result into a table row.  A run computes only what its
!> scene needs: the mass matrix only for P1, error integrals only when the scene has an
!> exact solution.  Output files are written under temporary names and renamed when the
!> run is complete, so a failed run leaves no partial file and keeps earlier results.
module dualsig_driver
  use, intrinsic :: iso_fortran_env, only: output_unit, error_unit, int64
  use, intrinsic :: iso_c_binding, only: c_int
  use dualsig_kinds, only: dp
  use dualsig_status, only: status_t, set_error, set_warning, is_ok, DS_ERR_INPUT, DS_OK, &
                            DS_WARN_NOT_CONVERGED, DS_WARN_NOT_CERTIFIED, DS_ERR_IO
  use dualsig_problem_kinds, only: PROBLEM_P1, PROBLEM_P2
  use dualsig_mesh, only: mesh_t, mesh_boundary_markers
  use dualsig_mesh_generate, only: mesh_rectangle, mesh_lshape, mesh_holed_square
  use dualsig_mesh_io, only: mesh_read_text, mesh_note_len
  use dualsig_mesh_gmsh, only: gmsh_physical_t, mesh_read_gmsh, gmsh_markers_from_names
  use dualsig_mesh_triangle, only: mesh_read_triangle, triangle_base_name
  use dualsig_mesh_quality, only: mesh_quality_t, mesh_quality, mesh_quality_report
  use dualsig_quadrature, only: tri_rule
  use dualsig_sparse_direct, only: ORDERING_BEST, ORDERING_AMD, ORDERING_METIS, ORDERING_NATURAL, ORDERING_GEOMETRIC
  use dualsig_dual_p2_field, only: dual_p2_lambda
  use dualsig_solver_boundary_schur, only: boundary_schur_max_default
  use dualsig_assembly_dual_hdiv, only: hdiv_point_value
  use dualsig_scenes, only: scene_t, scene_lookup
  use dualsig_estimate_errors, only: exact_energy
  use dualsig_analysis, only: analysis_problem_t, analysis_settings_t, level_result_t, analysis_t, &
                              analysis_start, analysis_next_level, exact_degree, analysis_next_step, &
                              analysis_adapt_stop, adapt_stop_text, certified_rel_error, ADAPT_GOING, &
                              adapt_max_steps, mg_auto_min_unknowns, analysis_free, analysis_aim_growth, &
                              adapt_aim_margin, adapt_aim_rate_max, analysis_limit_growth
  use dualsig_io_config, only: run_config_t, read_config_file, config_echo, config_text
  use dualsig_user_problem, only: user_problem_build, user_problem_description
  use dualsig_io_table, only: table_t, table_init, table_new_row, table_set, table_value, &
                              table_write_text, table_write_csv, table_format_row, &
                              table_format_header, observed_rate, table_show
  use dualsig_io_table, only: table_write_latex
  use dualsig_io_vtk, only: vtk_fields_t, vtk_write_level, vtk_write_collection, vtk_run_files, &
                            vtk_discard_run, vtk_level_path, vtk_contact_status, mesh_edges_write, vtk_remove_stale, &
                            mesh_edges_path
  use dualsig_strings, only: itoa, i8toa, rtoa, distinct_text
  use dualsig_clock, only: resident_memory_mb, peak_memory_mb
  use dualsig_io_files, only: file_commit_all, file_delete, temp_name, ensure_parent_dir, text_file_t, text_open, &
                              text_abandon, memory_available_gb, same_file
  use dualsig_alloc, only: alloc_failed, BYTES_REAL
  implicit none
  private

  public :: run_namelist_file, run_one, primal_columns, dual_columns, adapt_columns
  public :: progress_default_seconds, measured_level_memory_gb, memory_measured_margin, memory_limit_gb

  !> Bytes of a MiB (peak_memory_mb and resident_memory_mb count in MiB).
  real(dp), parameter :: mib_bytes = 1048576.0_dp
  !> The exact solutions of the catalogue live on the unit square; bounding-box tolerance.
  real(dp), parameter :: domain_tol = 1.0e-12_dp
  !> ParaView output: a Signorini node is shown in contact when u_h - obstacle <= this
  !> times max|u_h| (the solvers put contact nodes on the obstacle; this absorbs rounding).
  real(dp), parameter :: contact_rel_tol = 1.0e-12_dp
  !> Memory per triangle of a level (bytes), measured as the peak resident size of runs on
  !> the unit square at levels 5 to 8 (doc/user-guide.md, &run max_memory_gb), rounded up.
  real(dp), parameter :: p2_dual_bytes_per_tri = 5000.0_dp
  !> The P2 dual by its stream function and multigrid (O(N): no growth with the size):
  !> 1367-1459 bytes per triangle measured (peak resident size of uniform levels 9 and 10
  !> of p2_contact, the 2.6e6- and 1.08e7-triangle steps of the adaptive transition L-shape
  !> run; without the global P2 stiffness matrix and the stored C_e), a fifth or more as margin.
  real(dp), parameter :: p2_stream_dual_bytes_per_tri = 1750.0_dp
  real(dp), parameter :: p1_dual_bytes_per_tri = 3000.0_dp
  real(dp), parameter :: primal_factor_bytes_per_tri = 700.0_dp
  real(dp), parameter :: primal_bytes_per_tri = 250.0_dp
  !> After a level of at least memory_measured_min_tri triangles, the next level's memory is
  !> estimated from this run's own peak resident size per triangle of that level, times
  !> memory_measured_margin (measured_level_memory_gb), instead of the figures above: those
  !> hold for every problem with a fifth or more of margin.  With them a step of the smooth
  !> adaptive run to 1e-3 was refused as needing 24.7 GB (1.41e7 triangles at 1750 bytes)
  !> where the run had measured 1306 bytes a triangle (about 18.4 GB).
  integer(int64), parameter :: memory_measured_min_tri = 100000_int64
  real(dp), parameter :: memory_measured_margin = 1.2_dp
  !> An adaptive step whose estimate exceeds the memory is limited to the growth of the
  !> unknowns that fits (check_level_memory) when that is at least adapt_memory_min_growth
  !> (a smaller step would gain little: at rate 0.5 a growth of 1.2 lowers the error by
  !> 9 %); the fitting growth is searched downwards by memory_growth_shrink.
  real(dp), parameter :: adapt_memory_min_growth = 1.2_dp
  real(dp), parameter :: memory_growth_shrink = 0.98_dp

  !> Columns of the error table ('#' marks integer columns).
  character(len=16), parameter :: primal_columns(10) = [character(len=16) :: &
    '#level', 'h', '#ndof', '#primal_iters', 'primal_s', 'err_u_H1', 'rate_u_H1', &
    'err_u_L2', 'rate_u_L2', 'kkt_residual']
  !> Columns appended when the dual analysis runs (sqrt_est = sqrt(est); cert_rel_err =
  !> sqrt(est / energy_lo), the certified relative error, on certified rows).
  character(len=16), parameter :: dual_columns(15) = [character(len=16) :: &
    '#dual_iters', 'dual_s', 'err_q_Q', 'rate_q_Q', 'est', 'sqrt_est', 'eff', 'energy_lo', 'energy_hi', &
    'cert_rel_err', 'err_q_L2', 'rate_q_L2', 'err_lambda3', 'rate_lambda3', '#certified']
  !> Columns that need the exact solution (hidden from the text table without one).
  character(len=16), parameter :: exact_columns(11) = [character(len=16) :: &
    'err_u_H1', 'rate_u_H1', 'err_u_L2', 'rate_u_L2', 'err_q_Q', 'rate_q_Q', 'eff', &
    'err_q_L2', 'rate_q_L2', 'err_lambda3', 'rate_lambda3']
  !> Columns appended by an adaptive run (&adapt enabled): the observed rate of sqrt(est)
  !> in ndof, the certified relative error, marks, depth, smallest angle and timings.
  character(len=16), parameter :: adapt_columns(9) = [character(len=16) :: &
    'rate_est_ndof', 'rel_cert', '#nmarked', '#nheld', '#max_depth', 'min_angle', 'refine_s', 'estimate_s', 'elapsed_s']

  !> Progress on standard error: a phase of a level (analysis_progress) that lasts at least
  !> this many seconds is reported with its wall time; the environment variable
  !> DUALSIG_PROGRESS_SECONDS overrides it (0: every phase; a negative value: none).
  real(dp), parameter :: progress_default_seconds = 2.0_dp

  !> The state of the progress report of the current run (driver_progress).
  type :: progress_state_t
    character(len=:), allocatable :: title        !! the run's title
    character(len=8) :: unit_name = 'level'       !! 'level', or 'step' for an adaptive run
    real(dp) :: threshold = progress_default_seconds
    logical :: tty = .false.                      !! standard error is a terminal: show the running phase
    logical :: shown = .false.                    !! a running phase is shown on the terminal line
  end type progress_state_t
  type(progress_state_t), save :: progress

  interface
    !> isatty(3) of the C library: 1 when the descriptor is a terminal.
    integer(c_int) function c_isatty(fd) bind(c, name='isatty')
      import :: c_int
      integer(c_int), value :: fd
    end function c_isatty
  end interface

  !> A run as the driver sees it: the configuration, the problem built from it and what
  !> the header of the table needs.
  type :: run_t
    type(run_config_t) :: cfg
    character(len=:), allocatable :: title, where
    type(scene_t) :: scene
    type(analysis_problem_t) :: problem
    type(mesh_quality_t) :: q0                    !! quality of the coarse mesh
    logical :: by_names = .false.                 !! boundary parts given by Gmsh physical names
    integer :: nonconverged = 0                   !! warnings "iteration limit reached"
    integer :: uncertified = 0                    !! levels whose bounds are not certified
    logical :: adaptive = .false.                 !! &adapt enabled: steps instead of levels
    real(dp) :: min_angle = 180.0_dp              !! adaptive: smallest angle over the run's meshes
    character(len=:), allocatable :: stop_text    !! adaptive: why the loop stopped
  end type run_t

  !> A path of variable length (the input and output files of a run).
  type :: path_t
    character(len=:), allocatable :: s
  end type path_t

contains

  !> Run every run of the namelist file `path`, printing progress on `unit`
  !> (default: standard output).  Stops at the first run that fails; st carries a
  !> warning (DS_WARN_NOT_CONVERGED) when a solve hit its iteration limit.
  subroutine run_namelist_file(path, st, unit)
    character(len=*), intent(in) :: path
    type(status_t), intent(out) :: st
    integer, intent(in), optional :: unit
    type(run_config_t), allocatable :: runs(:)
    type(status_t) :: st_run
    integer :: r, out
    out = output_unit
    if (present(unit)) out = unit
    call read_config_file(path, runs, st)
    if (st%code /= 0) return
    ! every run's output must be writable before anything is computed
    do r = 1, size(runs)
      call check_output_writable(runs(r), st)
      if (st%code /= 0) return
    end do
    call check_distinct_outputs(runs, st)
    if (st%code /= 0) return
    do r = 1, size(runs)
      call run_one(runs(r), st_run, out)
      if (.not. is_ok(st_run)) then
        st = st_run
        if (r < size(runs)) st%msg = st%msg // '; the batch stopped there: ' // later_runs(runs(r + 1:))
        return
      end if
      if (st_run%code /= DS_OK) call set_warning(st, st_run%code, st_run%msg)
    end do
  end subroutine run_namelist_file

  !> The runs a failed run leaves out: 'the run of line 7 ("title") of f.nml was not run' or
  !> 'the runs of lines 7 ("a") and 9 ("b") of f.nml were not run'.
  function later_runs(rest) result(s)
    type(run_config_t), intent(in) :: rest(:)
    character(len=:), allocatable :: s
    integer :: k
    s = ''
    do k = 1, size(rest)
      if (k > 1 .and. k == size(rest)) then
        s = s // ' and '
      else if (k > 1) then
        s = s // ', '
      end if
      s = s // itoa(rest(k)%line) // ' ("' // trim(run_title(rest(k))) // '")'
    end do
    if (size(rest) == 1) then
      s = 'the run of line ' // s // ' of ' // trim(rest(1)%source_file) // ' was not run'
    else
      s = 'the runs of lines ' // s // ' of ' // trim(rest(1)%source_file) // ' were not run'
    end if
  end function later_runs

  !> The title of a run: &run title, else its output name.
  function run_title(cfg) result(s)
    type(run_config_t), intent(in) :: cfg
    character(len=:), allocatable :: s
    s = trim(cfg%title)
    if (len(s) == 0) s = trim(cfg%output)
  end function run_title

  !> One run (run_levels); a failed run leaves none of its files, not even the temporary
  !> .vtu files written level by level.
  subroutine run_one(cfg, st, unit, table)
    type(run_config_t), intent(in) :: cfg
    type(status_t), intent(out) :: st
    integer, intent(in) :: unit
    type(table_t), intent(out), optional :: table
    call run_levels(cfg, st, unit, table)
    if (.not. is_ok(st) .and. cfg%vtk) call vtk_discard_run(cfg%output, max_rows(cfg))
    if (.not. is_ok(st) .and. cfg%adapt_enabled) call file_delete(temp_name(mesh_edges_path(cfg%output)))
  end subroutine run_one

  !> One run: the problem and settings from cfg, then one analysis level after the other,
  !> each a table row (and a .vtu file on request); finally `<output>.txt` and
  !> `<output>.csv` (and `<output>.tex`, `<output>.pvd`), committed together.
  !>
  !> A level that fails (or whose estimated memory exceeds the limit) after at least one
  !> level finished stops the run, but the files of the finished levels are still written,
  !> complete, with a header line saying where and why the run stopped; st is the error of
  !> the level.  A write error discards every file of the run and keeps earlier ones.
  subroutine run_levels(cfg, st, unit, table)
    type(run_config_t), intent(in) :: cfg
    type(status_t), intent(out) :: st
    integer, intent(in) :: unit
    type(table_t), intent(out), optional :: table
    type(run_t) :: run
    type(analysis_settings_t) :: settings
    type(analysis_t) :: an
    type(level_result_t) :: res
    type(table_t) :: tab
    type(status_t) :: st_write
    type(run_config_t) :: defaults                    ! the defaults of every item (the notes)
    integer :: level, done, reason

    run%cfg = cfg
    run%title = run_title(cfg)
    run%where = cfg%source_file // ': run of line ' // itoa(cfg%line)
    call check_output_writable(cfg, st)
    if (st%code /= 0) return
    call build_problem(run, st, unit)
    if (st%code /= 0) return
    call ensure_parent_dir(trim(cfg%output) // '.txt', st)
    if (st%code /= 0) return
    run%adaptive = cfg%adapt_enabled
    if (run%adaptive) then
      call table_init(tab, [primal_columns, dual_columns, adapt_columns])
    else if (cfg%dual_enabled) then
      call table_init(tab, [primal_columns, dual_columns])
    else
      call table_init(tab, primal_columns)
    end if
    call show_computed_columns(run, tab)
    call settings_from_config(cfg, settings)
    call progress_start(run)
    settings%progress => driver_progress
    call analysis_start(an, run%problem, settings, st)
    if (st%code /= 0) then
      st%msg = run%where // ': ' // st%msg
      return
    end if

    if (cfg%has_problem) then
      write (unit, '(a)') 'dualsig: run "' // run%title // '" (&problem ' // trim(cfg%problem_kind) // &
        ', ' // trim(cfg%source_file) // ' line ' // itoa(cfg%line) // ')'
    else
      write (unit, '(a)') 'dualsig: run "' // run%title // '" (scene ' // trim(run%scene%name) // &
        ', ' // trim(cfg%source_file) // ' line ' // itoa(cfg%line) // ')'
    end if
    if (allocated(cfg%path_note)) then
      if (len(cfg%path_note) > 0) write (unit, '(a)') 'warning: ' // run%where // ': ' // cfg%path_note
    end if
    if (cfg%method /= 'psor' .and. (cfg%omega_auto .or. cfg%omega /= 1.0_dp)) write (unit, '(a)') 'note: ' // &
      run%where // ": &solver omega / omega_auto apply to method = 'psor' only; ignored with method = '" // &
      trim(cfg%method) // "' (the default is 'auto')"
    if (len(mesh_items_ignored(cfg, defaults)) > 0) write (unit, '(a)') 'note: ' // run%where // &
      ': &mesh ' // mesh_items_ignored(cfg, defaults) // " not used by source = '" // trim(cfg%mesh_source) // &
      "' (ignored)"
    if (cfg%adapt_enabled .and. cfg%levels /= defaults%levels) write (unit, '(a)') 'note: ' // &
      run%where // ': &mesh levels = ' // itoa(cfg%levels) // ' is ignored by an adaptive run (&adapt ' // &
      'enabled: its steps end at tol, max_ndof, max_seconds or ' // itoa(adapt_max_steps) // ' steps)'
    call mesh_quality_report(run%q0, unit)
    write (unit, '(a)') table_format_header(tab)
    done = 0
    reason = ADAPT_GOING
    do level = 1, max_rows(cfg)
      call check_level_memory(run, an, level, st, unit)
      if (.not. is_ok(st)) exit
      if (run%adaptive) then
        call analysis_next_step(an, res, st)
      else
        call analysis_next_level(an, res, st)
      end if
      call progress_clear()
      if (.not. is_ok(st)) then
        ! a mesh or assembly error names the run; a solver (numerical) error the run, its title and the level;
        ! after finished levels (the message below names the run) every error names its level
        if (res%ndof > 0 .or. done > 0) then
          st%msg = 'level ' // itoa(level) // ': ' // st%msg
          if (done == 0) st%msg = run%where // ' ("' // run%title // '"), ' // st%msg
        else
          st%msg = run%where // ': ' // st%msg
        end if
        exit
      end if
      call report_level(run, res, unit)
      call table_new_row(tab)
      call level_row(tab, res, run%problem%kind, run%adaptive)
      if (run%adaptive) call step_row(run, tab, an, res)
      if (cfg%vtk) call vtk_level(run, an%mesh, res, st)
      if (.not. is_ok(st)) then
        st%msg = run%where // ': ' // st%msg
        call analysis_free(an)
        return
      end if
      write (unit, '(a)') table_format_row(tab, level)
      flush (unit)
      done = level
      if (run%adaptive) then
        reason = analysis_adapt_stop(an, res)
        if (reason /= ADAPT_GOING) exit
      end if
    end do
    if (run%adaptive .and. is_ok(st)) then
      run%stop_text = adapt_stop_text(reason, settings%adapt)
      write (unit, '(a)') 'dualsig: adaptive loop stopped after step ' // itoa(done) // ' (' // &
        itoa(int(table_value(tab, done, 'ndof'))) // ' unknowns, certified relative error ' // &
        rel_text(certified_rel_error(res)) // ', smallest angle ' // rtoa(run%min_angle) // ' deg): ' // run%stop_text
    end if
    if (is_ok(st)) then
      call write_run_files(run, an%mesh, tab, done, '', st, unit)
    else if (done > 0 .and. res%exact_refuted) then
      ! u_exact refuted by a bound: the error columns of the finished levels are as wrong
      st%msg = run%where // ' ("' // run%title // '"), ' // st%msg // '; no tables written'
    else if (done > 0) then
      ! the finished levels survive the failure of a later one
      call write_run_files(run, an%mesh, tab, done, st%msg, st_write, unit)
      if (is_ok(st_write)) then
        st%msg = run%where // ' ("' // run%title // '"), ' // st%msg // '; the run stopped there: the tables of ' // &
          trim(merge('steps ', 'levels', run%adaptive)) // ' 1 to ' // itoa(done) // ' were written to ' // &
          trim(cfg%output) // '.txt and .csv'
      else
        st%msg = st%msg // '; writing the tables of levels 1 to ' // itoa(done) // ' failed too: ' // st_write%msg
      end if
    end if
    ! the hierarchy's coarsest CHOLMOD factor and the nested dual's data are not allocatable
    ! components: a run stopped before its last level (memory, a failed level) kept them
    call analysis_free(an)
    if (present(table)) table = tab
  end subroutine run_levels

  !> Prepare the progress report of a run: its title, the threshold (progress_default_seconds
  !> or DUALSIG_PROGRESS_SECONDS) and whether standard error is a terminal.
  subroutine progress_start(run)
    type(run_t), intent(in) :: run
    character(len=64) :: value
    integer :: n, stat, ios
    real(dp) :: seconds
    progress%title = run%title
    progress%unit_name = trim(merge('step ', 'level', run%adaptive))
    progress%threshold = progress_default_seconds
    call get_environment_variable('DUALSIG_PROGRESS_SECONDS', value, n, stat)
    if (stat == 0 .and. n > 0) then
      read (value, *, iostat=ios) seconds
      if (ios == 0) progress%threshold = seconds
    end if
    progress%tty = c_isatty(2_c_int) == 1
    progress%shown = .false.
  end subroutine progress_start

  !> The progress callback of the driver's runs (analysis_progress): a phase that took at
  !> least the threshold is reported on standard error as
  !> 'dualsig: run "title": level 7: primal solve 3.2 s'; on a terminal the running phase is
  !> shown meanwhile on a line of its own that the end of the phase clears.
  subroutine driver_progress(level, phase, finished, seconds)
    integer, intent(in) :: level
    character(len=*), intent(in) :: phase
    logical, intent(in) :: finished
    real(dp), intent(in) :: seconds
    character(len=:), allocatable :: label
    character(len=16) :: buf
    if (progress%threshold < 0.0_dp) return
    label = 'dualsig: run "' // progress%title // '": ' // trim(progress%unit_name) // ' ' // itoa(level) // ': ' // phase
    if (.not. finished) then
      if (.not. progress%tty) return
      call progress_clear()
      write (error_unit, '(a)', advance='no') label // ' ...'
      flush (error_unit)
      progress%shown = .true.
      return
    end if
    call progress_clear()
    if (seconds < progress%threshold) return
    write (buf, '(f16.1)') seconds
    write (error_unit, '(a)') label // ' ' // trim(adjustl(buf)) // ' s'
    flush (error_unit)
  end subroutine driver_progress

  !> Clear the terminal line of a running phase (driver_progress), if one is shown.
  subroutine progress_clear()
    if (.not. progress%shown) return
    write (error_unit, '(a)', advance='no') achar(13) // achar(27) // '[K'
    flush (error_unit)
    progress%shown = .false.
  end subroutine progress_clear

  !> The columns of the aligned text table (table_show): without an exact solution no error
  !> column; for P2 no P1-only dual error; with one level no rate; in an adaptive run no
  !> rel_cert (the same as cert_rel_err).  The CSV keeps every column.
  subroutine show_computed_columns(run, tab)
    type(run_t), intent(in) :: run
    type(table_t), intent(inout) :: tab
    integer :: k
    if (.not. run%scene%has_exact) then
      do k = 1, size(exact_columns)
        call table_show(tab, trim(exact_columns(k)), .false.)
      end do
    end if
    if (run%scene%problem /= PROBLEM_P1) then
      do k = 11, size(exact_columns)
        call table_show(tab, trim(exact_columns(k)), .false.)
      end do
    end if
    if (run%cfg%levels == 1 .and. .not. run%adaptive) then
      do k = 1, tab%ncol
        if (index(tab%name(k), 'rate_') == 1) tab%shown(k) = .false.
      end do
    end if
    call table_show(tab, 'rel_cert', .false.)
  end subroutine show_computed_columns

  !> Refuse level `level` when its estimated memory (level_memory_gb) exceeds &run
  !> max_memory_gb, or by default the machine's available memory.  An adaptive step that
  !> does not fit but would at a growth of at least adapt_memory_min_growth is limited to
  !> the growth that fits (analysis_limit_growth; a note on unit says so) instead: the run
  !> then goes as far as the memory allows, and stops for memory at the next step that
  !> cannot grow by that much.
  subroutine check_level_memory(run, an, level, st, unit)
    type(run_t), intent(in) :: run
    type(analysis_t), intent(inout) :: an
    integer, intent(in) :: level
    type(status_t), intent(out) :: st
    integer, intent(in) :: unit
    real(dp), parameter :: adapt_growth_margin = 1.1_dp
    real(dp) :: need, limit, growth, per_tri, fit
    integer(int64) :: ntri
    character(len=:), allocatable :: what, basis
    if (level == 1) then
      ntri = run%problem%mesh%ntri
    else if (run%adaptive) then
      ! a bisection step: at most twice the triangles; after two steps the larger of the
      ! last step's growth and min_growth (mark_and_refine's floor), with a tenth more
      growth = 2.0_dp
      if (an%prev_ndof > 0 .and. an%last_ndof > an%prev_ndof) &
        growth = min(2.0_dp, adapt_growth_margin * max(run%cfg%adapt_min_growth, &
                                                       real(an%last_ndof, dp) / real(an%prev_ndof, dp)))
      ! a step aiming at tol keeps its new nodes within the aim (analysis_aim_growth)
      if (analysis_aim_growth(an) > 0.0_dp) growth = analysis_aim_growth(an)
      ntri = int(growth * real(an%mesh%ntri, dp), int64)
    else
      ntri = 4_int64 * an%mesh%ntri                   ! one uniform refinement
    end if
    need = level_memory_gb(run%problem%kind, run%cfg%dual_enabled, run%cfg%method, ntri, stream_dual(run, an))
    basis = ''
    per_tri = 0.0_dp
    if (level > 1 .and. an%mesh%ntri >= memory_measured_min_tri .and. peak_memory_mb() > 0.0_dp) then
      per_tri = peak_memory_mb() * mib_bytes / real(an%mesh%ntri, dp)
      need = measured_level_memory_gb(per_tri, int(an%mesh%ntri, int64), ntri, stream_dual(run, an))
      basis = ' (this run''s peak so far, ' // itoa(nint(per_tri)) // ' bytes a triangle, times ' // &
              rtoa(memory_measured_margin) // ')'
    end if
    limit = run%cfg%max_memory_gb
    what = '&run max_memory_gb = ' // rtoa(limit)
    if (limit <= 0.0_dp) then
      limit = memory_limit_gb(limit, memory_available_gb(), resident_memory_mb())
      if (limit <= 0.0_dp) return                     ! unknown: no limit
      what = 'the available memory (MemAvailable of /proc/meminfo and this process''s resident memory) ' // &
             rtoa(limit) // ' GB'
    end if
    if (need <= limit) return
    if (run%adaptive .and. level > 1) then
      fit = memory_fitting_growth(run, an, per_tri, growth, need, limit)
      if (fit >= adapt_memory_min_growth) then
        call analysis_limit_growth(an, fit)
        write (unit, '(a)') 'note: ' // run%where // ': step ' // itoa(level) // ': ' // i8toa(ntri) // &
          ' triangles would need an estimated ' // rtoa(need) // ' GB' // basis // ', more than ' // what // &
          '; this step refines to at most ' // rtoa(fit) // ' times the unknowns instead'
        return
      end if
    end if
    if (run%adaptive) then
      call set_error(st, DS_ERR_INPUT, 'step ' // itoa(level) // ': ' // i8toa(ntri) // &
        ' triangles need an estimated ' // rtoa(need) // ' GB' // basis // ', more than ' // what // &
        ' (expected a larger &adapt tol or a smaller max_ndof, or a larger &run max_memory_gb)')
    else
      call set_error(st, DS_ERR_INPUT, 'level ' // itoa(level) // ': ' // i8toa(ntri) // &
        ' triangles need an estimated ' // rtoa(need) // ' GB' // basis // ', more than ' // what // &
        ' (expected fewer &mesh levels, or a larger &run max_memory_gb)')
    end if
  end subroutine check_level_memory

  !> The largest growth of an adaptive step (at most `growth`, in steps of
  !> memory_growth_shrink) whose estimated memory, as check_level_memory estimates it
  !> (per_tri > 0: this run's measured peak per triangle, else level_memory_gb), is within
  !> limit GB; 1 when none above adapt_memory_min_growth is.
  function memory_fitting_growth(run, an, per_tri, growth, need, limit) result(fit)
    type(run_t), intent(in) :: run
    type(analysis_t), intent(in) :: an
    real(dp), intent(in) :: per_tri, growth, need, limit
    real(dp) :: fit, est
    integer(int64) :: ntri
    fit = growth * limit / need                       ! exact for a linear estimate
    do while (fit >= adapt_memory_min_growth)
      ntri = int(fit * real(an%mesh%ntri, dp), int64)
      if (per_tri > 0.0_dp) then
        est = measured_level_memory_gb(per_tri, int(an%mesh%ntri, int64), ntri, stream_dual(run, an))
      else
        est = level_memory_gb(run%problem%kind, run%cfg%dual_enabled, run%cfg%method, ntri, stream_dual(run, an))
      end if
      if (est <= limit) then
        fit = real(floor(fit * 1000.0_dp), dp) / 1000.0_dp   ! (printed with three decimals)
        return
      end if
      fit = fit * memory_growth_shrink
    end do
    fit = 1.0_dp
  end function memory_fitting_growth

  !> The memory (GB) a level may use: max_memory_gb when it is set (> 0), else the machine's
  !> available memory (available_gb, MemAvailable; <= 0: unknown, then the result is <= 0,
  !> no limit) plus what this process holds already (resident_mb MiB: its live data and the
  !> heap it keeps for reuse, dualsig_heap), since a level's estimate is the whole process's
  !> peak.
  pure real(dp) function memory_limit_gb(max_memory_gb, available_gb, resident_mb) result(limit)
    real(dp), intent(in) :: max_memory_gb, available_gb, resident_mb
    limit = max_memory_gb
    if (limit > 0.0_dp) return
    limit = available_gb
    if (limit <= 0.0_dp) return
    limit = limit + max(resident_mb, 0.0_dp) * mib_bytes / 1.0e9_dp
  end function memory_limit_gb

  !> The level's P2 dual will be the stream function by multigrid (dualsig_analysis's
  !> p2_dual_choice, for the sizes where memory matters): method 'default' or 'multigrid',
  !> the polynomial lambda^f, a simply connected domain.
  pure logical function stream_dual(run, an)
    type(run_t), intent(in) :: run
    type(analysis_t), intent(in) :: an
    integer :: nloop
    nloop = run%problem%mesh%nloop
    if (an%level > 0) nloop = an%mesh%nloop
    stream_dual = run%problem%kind == PROBLEM_P2 .and. run%cfg%dual_enabled .and. &
                  any(run%cfg%dual_method == [character(len=16) :: 'default', 'multigrid']) .and. &
                  run%cfg%dual_particular == 'polynomial' .and. nloop == 1
  end function stream_dual

  !> Estimated peak memory (GB) of one level of ntri triangles: a fixed part, and per
  !> triangle what the solvers measured on the unit square (P2 dual: the equilibrium
  !> elements and their CHOLMOD factor, or with stream the stream function's multigrid; P1
  !> dual: the vector field and its factor; the primal alone: the matrix, and the factor
  !> for the active-set method), growing like the fill of a nested-dissection factor,
  !> n log n, beyond 131072 triangles (not for the stream function's O(N) multigrid).
  pure real(dp) function level_memory_gb(kind, dual, method, ntri, stream) result(gb)
    integer, intent(in) :: kind
    logical, intent(in) :: dual
    character(len=*), intent(in) :: method
    integer(int64), intent(in) :: ntri
    logical, intent(in) :: stream
    real(dp), parameter :: base_bytes = 16.0e6_dp            !! program, libraries, coarse data
    real(dp), parameter :: calibration_ntri = 131072.0_dp    !! 2x2 square, level 8
    real(dp) :: per_tri
    if (stream) then
      gb = (base_bytes + p2_stream_dual_bytes_per_tri * real(ntri, dp)) / 1.0e9_dp
      return
    end if
    if (dual .and. kind == PROBLEM_P1) then
      per_tri = p1_dual_bytes_per_tri
    else if (dual) then
      per_tri = p2_dual_bytes_per_tri
    else if (method /= 'psor' .and. method /= 'multigrid') then
      per_tri = primal_factor_bytes_per_tri
    else
      per_tri = primal_bytes_per_tri
    end if
    gb = (base_bytes + per_tri * real(ntri, dp) * &
          max(1.0_dp, log(real(ntri, dp)) / log(calibration_ntri))) / 1.0e9_dp
  end function level_memory_gb

  !> Estimated peak memory (GB) of a level of ntri triangles from a run's measured peak
  !> resident size per triangle of its last level (ntri_prev triangles), times
  !> memory_measured_margin; with the n log n growth of a factor's fill (as
  !> level_memory_gb) unless the level is O(N) (linear: the stream function's multigrid).
  pure real(dp) function measured_level_memory_gb(per_tri, ntri_prev, ntri, linear) result(gb)
    real(dp), intent(in) :: per_tri
    integer(int64), intent(in) :: ntri_prev, ntri
    logical, intent(in) :: linear
    real(dp) :: fill
    fill = 1.0_dp
    if (.not. linear .and. ntri_prev > 1) fill = max(1.0_dp, log(real(ntri, dp)) / log(real(ntri_prev, dp)))
    gb = memory_measured_margin * per_tri * real(ntri, dp) * fill / 1.0e9_dp
  end function measured_level_memory_gb

  !> The analysis problem of a run: the scene (load, exact solution, default boundary
  !> parts) or &problem, the coarse mesh (generator or file) and the boundary markers; the
  !> quality of the coarse mesh for the table header.
  subroutine build_problem(run, st, unit)
    type(run_t), intent(inout) :: run
    type(status_t), intent(out) :: st
    integer, intent(in) :: unit
    type(gmsh_physical_t) :: phys
    associate (cfg => run%cfg, pb => run%problem)
      if (cfg%has_problem) then
        run%scene%name = '&problem'
        run%scene%description = user_problem_description(cfg)
        run%scene%problem = merge(PROBLEM_P1, PROBLEM_P2, cfg%problem_kind == 'P1')
      else
        call scene_lookup(cfg%scene, run%scene, st)
        if (st%code /= 0) then
          st%msg = cfg%source_file // ': &run scene: ' // st%msg
          return
        end if
      end if
      if (any(cfg%gamma_u_markers /= 0) .or. any(cfg%gamma_a_markers /= 0)) then
        pb%gamma_u = cfg%gamma_u_markers
        pb%gamma_a = cfg%gamma_a_markers
      else
        pb%gamma_u = run%scene%gamma_u_markers
        pb%gamma_a = run%scene%gamma_a_markers
      end if
      call coarse_mesh(cfg, pb%mesh, phys, st, unit)
      if (st%code /= 0) then
        st%msg = run%where // ', &mesh: ' // st%msg
        return
      end if
      run%by_names = any(cfg%gamma_u_names /= '') .or. any(cfg%gamma_a_names /= '')
      if (run%by_names) then
        call boundary_by_names(run, phys, st, unit)
        if (st%code /= 0) return
      end if
      if (cfg%has_problem) then
        call default_boundary_parts(run, cfg%problem_kind == 'P1', .false., unit)
        call check_boundary_parts(run, st, unit)
        if (st%code /= 0) return
        call user_problem_build(cfg, phys, pb, st)
        if (st%code /= 0) return
        run%scene%has_exact = allocated(pb%u_exact)
        if (run%scene%has_exact) then
          allocate (run%scene%u, source=pb%u_exact)            ! small: a compiled expression
          allocate (run%scene%grad_u, source=pb%grad_exact)    ! small: a compiled expression
        end if
        run%q0 = mesh_quality(pb%mesh)
        return
      end if
      if (run%scene%has_exact .and. run%scene%domain == 'unit_square') then
        if (.not. on_unit_square(pb%mesh)) then
          call set_error(st, DS_ERR_INPUT, run%where // ': scene ' // trim(run%scene%name) // &
            ' has its exact solution on the unit square (0,1)^2; the mesh covers another domain')
          return
        end if
      end if
      pb%kind = run%scene%problem
      call default_boundary_parts(run, pb%kind == PROBLEM_P1, .true., unit)
      call check_boundary_parts(run, st, unit)
      if (st%code /= 0) return
      ! (allocate with source: gfortran 12 mis-assigns to an allocated polymorphic component)
      allocate (pb%f, source=run%scene%f)                ! small: a scene's function field
      pb%x_breaks = run%scene%x_breaks(1:run%scene%nbreaks)
      if (run%scene%has_exact) then
        allocate (pb%u_exact, source=run%scene%u)          ! small: a scene's function field
        allocate (pb%grad_exact, source=run%scene%grad_u)  ! small: a scene's function field
      end if
      run%q0 = mesh_quality(pb%mesh)
    end associate
  end subroutine build_problem

  !> The boundary parts against the coarse mesh, in the terms the run gave them (the
  !> library checks the markers again, but cannot name what the user wrote): a name in both
  !> &run gamma_u_names and gamma_a_names, or a scene's default marker that the mesh does
  !> not have (the scene's parts belong to its own mesh), is DS_ERR_INPUT; a marker or a
  !> name listed twice in one list gets a note (the part counts once).
  subroutine check_boundary_parts(run, st, unit)
    type(run_t), intent(in) :: run
    type(status_t), intent(out) :: st
    integer, intent(in) :: unit
    integer :: k
    associate (cfg => run%cfg, pb => run%problem)
      if (run%by_names) then
        do k = 1, size(cfg%gamma_u_names)
          if (len_trim(cfg%gamma_u_names(k)) == 0) cycle
          if (any(cfg%gamma_a_names == cfg%gamma_u_names(k))) then
            call set_error(st, DS_ERR_INPUT, run%where // ": &run gamma_u_names and gamma_a_names both list '" // &
              trim(cfg%gamma_u_names(k)) // "' (expected each boundary part in one of them)")
            return
          end if
        end do
        call note_repeated_names(run, cfg%gamma_u_names, 'gamma_u_names', unit)
        call note_repeated_names(run, cfg%gamma_a_names, 'gamma_a_names', unit)
      else if (any(cfg%gamma_u_markers /= 0) .or. any(cfg%gamma_a_markers /= 0)) then
        call note_repeated_markers(run, cfg%gamma_u_markers, 'gamma_u_markers', unit)
        call note_repeated_markers(run, cfg%gamma_a_markers, 'gamma_a_markers', unit)
      else
        call check_scene_markers(run, pb%gamma_u, st)
        if (st%code == 0) call check_scene_markers(run, pb%gamma_a, st)
      end if
    end associate
  end subroutine check_boundary_parts

  !> DS_ERR_INPUT when one of a scene's default `markers` does not occur on the mesh.
  subroutine check_scene_markers(run, markers, st)
    type(run_t), intent(in) :: run
    integer, intent(in) :: markers(:)
    type(status_t), intent(inout) :: st
    integer :: k
    do k = 1, size(markers)
      if (markers(k) <= 0 .or. any(run%problem%mesh%bedge_marker == markers(k))) cycle
      call set_error(st, DS_ERR_INPUT, run%where // ': the default boundary parts of scene ' // &
        trim(run%scene%name) // ' are the markers of its own domain (the scene table of the user ' // &
        'guide), and its marker ' // itoa(markers(k)) // ' does not occur on this mesh, whose markers are ' // &
        distinct_text(run%problem%mesh%bedge_marker) // ' (expected the scene''s domain, or &run ' // &
        'gamma_u_markers and gamma_a_markers with the markers of this mesh)')
      return
    end do
  end subroutine check_scene_markers

  !> A note for every name given more than once in the list `item` of &run.
  subroutine note_repeated_names(run, names, item, unit)
    type(run_t), intent(in) :: run
    character(len=*), intent(in) :: names(:)
    character(len=*), intent(in) :: item
    integer, intent(in) :: unit
    integer :: k
    do k = 2, size(names)
      if (len_trim(names(k)) == 0) cycle
      if (any(names(1:k - 1) == names(k)) .and. .not. any(names(k + 1:) == names(k))) &
        write (unit, '(a)') 'note: ' // run%where // ': &run ' // item // " lists '" // trim(names(k)) // &
          "' " // itoa(count(names == names(k))) // ' times (the part counts once)'
    end do
  end subroutine note_repeated_names

  !> A note for every marker given more than once in the list `item` of &run.
  subroutine note_repeated_markers(run, markers, item, unit)
    type(run_t), intent(in) :: run
    integer, intent(in) :: markers(:)
    character(len=*), intent(in) :: item
    integer, intent(in) :: unit
    integer :: k
    do k = 2, size(markers)
      if (markers(k) <= 0) cycle
      if (any(markers(1:k - 1) == markers(k)) .and. .not. any(markers(k + 1:) == markers(k))) &
        write (unit, '(a)') 'note: ' // run%where // ': &run ' // item // ' lists marker ' // itoa(markers(k)) // &
          ' ' // itoa(count(markers == markers(k))) // ' times (the part counts once)'
    end do
  end subroutine note_repeated_markers

  !> Boundary parts when &run gives neither markers nor names: P1 has Signorini conditions
  !> on the whole boundary (every marker of the mesh in Gamma_a), for a scene too (its
  !> default markers are those of the generated meshes); a P2 &problem gets u = 0 on the
  !> whole boundary, a P2 scene keeps its default parts.  A P2 problem without Gamma_a has
  !> no contact: a warning says so.
  subroutine default_boundary_parts(run, is_p1, from_scene, unit)
    type(run_t), intent(inout) :: run
    logical, intent(in) :: is_p1        !! problem P1
    logical, intent(in) :: from_scene   !! the problem is a scene (not &problem)
    integer, intent(in) :: unit
    integer, allocatable :: markers(:)
    associate (cfg => run%cfg, pb => run%problem)
      if (.not. (run%by_names .or. any(cfg%gamma_u_markers /= 0) .or. any(cfg%gamma_a_markers /= 0))) then
        markers = mesh_boundary_markers(pb%mesh)
        if (is_p1) then
          pb%gamma_u = [integer ::]
          pb%gamma_a = markers
        else if (.not. from_scene) then
          pb%gamma_u = markers
          pb%gamma_a = [integer ::]
        end if
      end if
      if (.not. is_p1 .and. .not. any(pb%gamma_a > 0)) write (unit, '(a)') 'warning: ' // &
        run%where // ': problem P2 without Gamma_a: u = 0 on all of the boundary, a Dirichlet problem without ' // &
        'contact (expected &run gamma_a_markers or gamma_a_names for the Signorini part)'
    end associate
  end subroutine default_boundary_parts

  !> True when the bounding box of the mesh is the unit square (to domain_tol).
  logical function on_unit_square(mesh)
    type(mesh_t), intent(in) :: mesh
    on_unit_square = abs(minval(mesh%xy(1, :))) <= domain_tol .and. abs(maxval(mesh%xy(1, :)) - 1.0_dp) <= domain_tol &
      .and. abs(minval(mesh%xy(2, :))) <= domain_tol .and. abs(maxval(mesh%xy(2, :)) - 1.0_dp) <= domain_tol
  end function on_unit_square

  !> The coarse mesh of &mesh: a generator, or a file (format 'auto': a name ending in .msh
  !> is Gmsh; a Triangle file (.node, .ele, .poly, .edge) or a base name with .node and .ele
  !> files is Triangle; anything else the dualsig format).  Notes of the readers and a
  !> note for a mesh whose triangles were all clockwise (all reoriented) are printed on unit.
  subroutine coarse_mesh(cfg, mesh, phys, st, unit)
    type(run_config_t), intent(in) :: cfg
    type(mesh_t), intent(out) :: mesh
    type(gmsh_physical_t), intent(out) :: phys
    type(status_t), intent(out) :: st
    integer, intent(in) :: unit
    character(len=mesh_note_len), allocatable :: mesh_notes(:)
    character(len=:), allocatable :: mesh_format, tri_base
    logical :: is_triangle
    integer :: nflip, inote, k
    nflip = 0
    select case (trim(cfg%mesh_source))
    case ('rectangle')
      call mesh_rectangle(mesh, cfg%x0, cfg%x1, cfg%y0, cfg%y1, cfg%nx, cfg%ny, cfg%pattern, st)
    case ('lshape')
      call mesh_lshape(mesh, cfg%n, st)
    case ('holed_square')
      call mesh_holed_square(mesh, cfg%n, st)
    case ('file')
      mesh_format = trim(cfg%mesh_format)
      if (mesh_format == 'auto') then
        call triangle_base_name(trim(cfg%mesh_file), tri_base, is_triangle)
        mesh_format = trim(merge('triangle', 'dualsig ', is_triangle))
        k = len_trim(cfg%mesh_file)
        if (k > len('.msh')) then
          if (cfg%mesh_file(k - 3:k) == '.msh') mesh_format = 'gmsh'
        end if
      end if
      select case (mesh_format)
      case ('gmsh')
        call mesh_read_gmsh(trim(cfg%mesh_file), mesh, phys, st, nflip, mesh_notes)
      case ('triangle')
        call mesh_read_triangle(trim(cfg%mesh_file), mesh, st, nflip, mesh_notes)
      case default
        call mesh_read_text(trim(cfg%mesh_file), mesh, st, nflip)
      end select
      if (allocated(mesh_notes)) then
        do inote = 1, size(mesh_notes)
          write (unit, '(a)') "note: mesh file '" // trim(cfg%mesh_file) // "': " // trim(mesh_notes(inote))
        end do
      end if
    end select
    if (st%code /= 0) return
    if (nflip > 0) write (unit, '(a,i0,a)') "note: mesh file '" // trim(cfg%mesh_file) // "': all ", nflip, &
      ' triangles are clockwise: all reoriented (n2 and n3 swapped; counter-clockwise vertices are the convention)'
  end subroutine coarse_mesh

  !> Boundary parts by Gmsh physical-curve name: the markers are the physical tags.
  subroutine boundary_by_names(run, phys, st, unit)
    type(run_t), intent(inout) :: run
    type(gmsh_physical_t), intent(in) :: phys
    type(status_t), intent(out) :: st
    integer, intent(in) :: unit
    character(len=300) :: line
    integer :: k
    associate (cfg => run%cfg, pb => run%problem)
      call gmsh_markers_from_names(phys, cfg%gamma_u_names, '&run gamma_u_names', trim(cfg%mesh_file), pb%gamma_u, st)
      if (st%code == 0) call gmsh_markers_from_names(phys, cfg%gamma_a_names, '&run gamma_a_names', &
                                                     trim(cfg%mesh_file), pb%gamma_a, st)
      if (st%code /= 0) then
        st%msg = run%where // ': ' // st%msg
        return
      end if
      line = 'boundary by name: Gamma_u markers'
      do k = 1, size(pb%gamma_u)
        if (pb%gamma_u(k) /= 0) line = trim(line) // ' ' // itoa(pb%gamma_u(k))
      end do
      line = trim(line) // ', Gamma_a markers'
      do k = 1, size(pb%gamma_a)
        if (pb%gamma_a(k) /= 0) line = trim(line) // ' ' // itoa(pb%gamma_a(k))
      end do
      write (unit, '(a)') trim(line)
    end associate
  end subroutine boundary_by_names

  !> The analysis settings of &solver and &dual.
  subroutine settings_from_config(cfg, settings)
    type(run_config_t), intent(in) :: cfg
    type(analysis_settings_t), intent(out) :: settings
    settings%levels = cfg%levels
    settings%nested = cfg%nested
    settings%method = cfg%method
    settings%omega = cfg%omega
    settings%omega_auto = cfg%omega_auto
    settings%tol = cfg%tol
    settings%max_iter = cfg%max_iter
    settings%check_every = cfg%check_every
    select case (trim(cfg%dual_ordering))
    case ('nd')
      settings%ordering = ORDERING_GEOMETRIC
    case ('amd')
      settings%ordering = ORDERING_AMD
    case ('metis')
      settings%ordering = ORDERING_METIS
    case ('natural')
      settings%ordering = ORDERING_NATURAL
    case ('best')
      settings%ordering = ORDERING_BEST
    case default
      settings%ordering = ORDERING_AMD
    end select
    settings%dual = cfg%dual_enabled
    settings%dual_method = cfg%dual_method
    settings%dual_rho = cfg%dual_rho
    settings%dual_tol = cfg%dual_tol
    settings%dual_tol_h2 = cfg%dual_tol_h2
    settings%dual_max_iter = cfg%dual_max_iter
    settings%dual_inner = cfg%dual_inner
    settings%dual_particular = cfg%dual_particular
    settings%dual_algebraic_share = cfg%dual_algebraic_share
    settings%dual_space = cfg%dual_space
    settings%keep_fields = cfg%vtk
    settings%adapt%enabled = cfg%adapt_enabled
    settings%adapt%theta = cfg%adapt_theta
    settings%adapt%tol = cfg%adapt_tol
    settings%adapt%max_ndof = cfg%adapt_max_ndof
    settings%adapt%max_seconds = cfg%adapt_max_seconds
    settings%adapt%min_growth = cfg%adapt_min_growth
    settings%adapt%algebraic_share = cfg%adapt_algebraic_share
  end subroutine settings_from_config

  !> The most table rows of a run: its levels, or for an adaptive run the most steps.
  pure integer function max_rows(cfg)
    type(run_config_t), intent(in) :: cfg
    max_rows = cfg%levels
    if (cfg%adapt_enabled) max_rows = adapt_max_steps
  end function max_rows

  !> The adaptive columns of the current row: the observed rate p of sqrt(est) ~ ndof^(-p)
  !> against the previous step, the certified relative error, marks, depth, the smallest
  !> angle of the step's mesh (and over the run, in run%min_angle) and the timings.
  subroutine step_row(run, tab, an, res)
    type(run_t), intent(inout) :: run
    type(table_t), intent(inout) :: tab
    type(analysis_t), intent(in) :: an
    type(level_result_t), intent(in) :: res
    type(mesh_quality_t) :: q
    real(dp) :: r, rel
    logical :: ok
    q = mesh_quality(an%mesh)
    run%min_angle = min(run%min_angle, q%min_angle_deg)
    call table_set(tab, 'min_angle', q%min_angle_deg)
    call table_set(tab, 'nmarked', real(res%nmarked, dp))
    call table_set(tab, 'nheld', real(res%nheld, dp))
    call table_set(tab, 'max_depth', real(res%max_depth, dp))
    call table_set(tab, 'refine_s', res%refine_seconds)
    call table_set(tab, 'estimate_s', res%estimate_seconds)
    call table_set(tab, 'elapsed_s', res%elapsed_seconds)
    rel = certified_rel_error(res)
    if (rel < huge(1.0_dp)) call table_set(tab, 'rel_cert', rel)
    if (res%level > 1 .and. res%has_dual) then
      call observed_rate(sqrt(max(table_value(tab, res%level - 1, 'est'), 0.0_dp)), sqrt(max(res%est, 0.0_dp)), &
                         1.0_dp / table_value(tab, res%level - 1, 'ndof'), 1.0_dp / real(res%ndof, dp), r, ok)
      if (ok) call table_set(tab, 'rate_est_ndof', r)
    end if
  end subroutine step_row

  !> The warnings and the dual solver's report of a level, on unit.
  subroutine report_level(run, res, unit)
    type(run_t), intent(inout) :: run
    type(level_result_t), intent(in) :: res
    integer, intent(in) :: unit
    integer :: k
    do k = 1, res%nwarnings
      if (res%warnings(k)%code == DS_WARN_NOT_CONVERGED) run%nonconverged = run%nonconverged + 1
      if (res%warnings(k)%code == DS_WARN_NOT_CERTIFIED .and. res%has_dual .and. &
          res%dual_p2%defect > 0.0_dp .and. index(res%warnings(k)%msg, 'divergence defect') > 0) then
        write (unit, '(a,i0,a,es9.2,a)') 'warning: level ', res%level, ': the dual field has a divergence defect ', &
          res%dual_p2%defect, ' (relative): lambda_h is not admissible and est is NOT a guaranteed bound' // &
          ' (even after the exact equilibration of the solver''s field)'
      else
        write (unit, '(a)') 'warning: level ' // itoa(res%level) // ': ' // res%warnings(k)%msg
      end if
    end do
    if (res%has_dual .and. .not. res%certified) run%uncertified = run%uncertified + 1
    write (unit, '(a,i0,a,i0,a,i0,a)') '  primal level ' // itoa(res%level) // ': ' // trim(res%primal_method) // ', ', &
      res%primal_iters, ' ' // trim(primal_steps(res%primal_method)) // ', ', res%primal_factorisations, ' ' // &
      trim(merge('Galerkin updates', 'factorisations  ', index(res%primal_method, 'multigrid') == 1)) // ', ', &
      res%ndof, ' unknowns'
    if (.not. res%has_dual) return
    if (run%problem%kind == PROBLEM_P1) then
      associate (d => res%dual_p1)
        write (unit, '(a,i0,a,i0,a,a,a,i0,a,i0,a,i0,a,es9.2,a,i0,a,i0,a,a)') '  dual level ', res%level, ': ', &
          d%iterations, ' iterations (', trim(res%dual_method), '), factorisations ', d%factorisations, &
          ', bordered ', d%lowrank_solves, ', nnz(L) = ', d%nnz_factor, ', residual ', d%residual, &
          ', constraints ', d%nconstraints, ', active ', d%nactive, ', space ', trim(res%dual_space)
        if (res%dual_method == 'uzawa') write (unit, '(a,es10.3,a,es10.3,a,i0)') '    rho = ', d%rho, &
          ', lambda_max(B A^-1 B^T) ~ ', d%lambda_max, ', retries ', d%retries
        write (unit, '(a,a)') '    ordering ', trim(d%ordering)
      end associate
    else
      associate (d => res%dual_p2)
        write (unit, '(a,i0,a,i0,a,a,a,i0,a,i0,a,es9.2,a,es9.2,a,i0,a,i0)') '  dual level ', res%level, ': ', &
          d%iterations, ' iterations (', trim(res%dual_method), '), factorisations ', d%factorisations, &
          ', nnz(L) = ', d%nnz_factor, ', divergence defect ', d%defect, ' (solver ', d%defect_solver, &
          '), constraints ', d%nconstraints, ', active ', d%nactive
        if (res%dual_method == 'uzawa') write (unit, '(a,es10.3,a,es10.3,a,es9.2)') '    rho = ', d%rho, &
          ', lambda_max(B A^-1 B^T) ~ ', d%lambda_max, ', residual ', d%residual
        if (res%dual_method == 'augmented') write (unit, '(a,es10.3,a,a)') '    penalty r = ', d%penalty, &
          ', ordering ', trim(d%ordering)
        if (res%dual_method == 'multigrid') write (unit, '(a,i0,a,i0,a,i0,a)') '    stream function: ', &
          d%inner_iterations, ' V-cycles and ', d%sweeps, ' Gauss-Seidel sweeps in ', d%iterations, &
          ' active-set steps (' // trim(d%inner) // trim(stream_grids(d%inner)) // ')'
        if (d%est_gap > 0.0_dp) write (unit, '(a,es9.2,a)') '    stopped at the algebraic share: est + ', &
          d%est_gap, ' (predicted part of est the solve left)'
      end associate
    end if
  end subroutine report_level

  !> The grids of the P2 dual's stream-function multigrid, for the report: by the inner
  !> solver name of dualsig_problem_dual_p2 ('multigrid': the refinements' grids;
  !> 'gauss_seidel': the sweeps of the last level reached the share without any).
  pure function stream_grids(inner) result(text)
    character(len=*), intent(in) :: inner
    character(len=:), allocatable :: text
    select case (trim(inner))
    case ('multigrid')
      text = ', geometric grids'
    case ('multigrid_p1amg')
      text = ', the P1 grid and aggregation below it'
    case ('gauss_seidel')
      text = ', no grids: sweeps from the previous level''s psi'
    case default
      text = ', aggregation'
    end select
  end function stream_grids

  !> What primal_iters counts for a primal method (the column's unit).
  pure function primal_steps(method) result(steps)
    character(len=*), intent(in) :: method
    character(len=:), allocatable :: steps
    select case (trim(method))
    case ('multigrid', 'multigrid_amg')
      steps = 'V-cycles'
    case ('schur')
      steps = 'pivoting steps'
    case ('active_set')
      steps = 'active-set iterations'
    case default
      steps = 'sweeps'
    end select
  end function primal_steps

  !> The columns of the current table row from a level's result; rates are the observed
  !> orders against the previous row.
  subroutine level_row(tab, res, kind, adaptive)
    type(table_t), intent(inout) :: tab
    type(level_result_t), intent(in) :: res
    integer, intent(in) :: kind             !! PROBLEM_P1 or PROBLEM_P2
    logical, intent(in) :: adaptive         !! rates against ndof^(-1/2) instead of h
    call table_set(tab, 'level', real(res%level, dp))
    call table_set(tab, 'h', res%h)
    call table_set(tab, 'ndof', real(res%ndof, dp))
    call table_set(tab, 'primal_iters', real(res%primal_iters, dp))
    call table_set(tab, 'primal_s', res%primal_seconds)
    call table_set(tab, 'kkt_residual', res%kkt_residual)
    if (res%has_exact) then
      call set_with_rate(tab, res, adaptive, 'err_u_H1', 'rate_u_H1', res%err_energy)
      call set_with_rate(tab, res, adaptive, 'err_u_L2', 'rate_u_L2', res%err_l2)
    end if
    if (.not. res%has_dual) return
    call table_set(tab, 'dual_iters', real(res%dual_iters, dp))
    call table_set(tab, 'dual_s', res%dual_seconds)
    call table_set(tab, 'est', res%est)
    call table_set(tab, 'sqrt_est', sqrt(max(res%est, 0.0_dp)))
    call table_set(tab, 'energy_lo', res%energy_lo)
    call table_set(tab, 'energy_hi', res%energy_hi)
    if (certified_rel_error(res) < huge(1.0_dp)) call table_set(tab, 'cert_rel_err', certified_rel_error(res))
    call table_set(tab, 'certified', merge(1.0_dp, 0.0_dp, res%certified))
    if (res%has_exact) then
      if (kind == PROBLEM_P1) then
        ! ||q - grad u||, ||f + div q - u|| and their combination
        call set_with_rate(tab, res, adaptive, 'err_q_Q', 'rate_q_Q', res%err_q_norm)
        call set_with_rate(tab, res, adaptive, 'err_q_L2', 'rate_q_L2', res%err_q)
        call set_with_rate(tab, res, adaptive, 'err_lambda3', 'rate_lambda3', res%err_div)
      else
        ! ||grad u - lambda_h||
        call set_with_rate(tab, res, adaptive, 'err_q_Q', 'rate_q_Q', res%err_q)
      end if
      if (res%err_energy > 0.0_dp) call table_set(tab, 'eff', sqrt(res%est) / res%err_energy)
    end if
  end subroutine level_row

  !> Set column `name` of the current row to `value` and `rate_name` to its observed order
  !> against the previous row.
  subroutine set_with_rate(tab, res, adaptive, name, rate_name, value)
    type(table_t), intent(inout) :: tab
    type(level_result_t), intent(in) :: res
    logical, intent(in) :: adaptive
    character(len=*), intent(in) :: name, rate_name
    real(dp), intent(in) :: value
    real(dp) :: r
    logical :: ok
    call table_set(tab, name, value)
    if (res%level == 1) return
    if (adaptive) then
      ! graded meshes: h hardly changes; the order in the equivalent mesh size ndof^(-1/2)
      call observed_rate(table_value(tab, res%level - 1, name), value, table_value(tab, res%level - 1, 'ndof')**(-0.5_dp), &
                         real(res%ndof, dp)**(-0.5_dp), r, ok)
    else
      call observed_rate(table_value(tab, res%level - 1, name), value, table_value(tab, res%level - 1, 'h'), &
                         res%h, r, ok)
    end if
    if (ok) call table_set(tab, rate_name, r)
  end subroutine set_with_rate

  !> Write the .vtu of the level under its temporary name (committed with the tables at
  !> the end of the run): u_h, the exact u, the contact status, the dual field and the
  !> estimator contributions.
  subroutine vtk_level(run, mesh, res, st)
    type(run_t), intent(in) :: run
    type(mesh_t), intent(in) :: mesh
    type(level_result_t), intent(in) :: res
    type(status_t), intent(out) :: st
    type(vtk_fields_t) :: vfields
    integer :: i, j, ist
    if (allocated(run%problem%u_exact)) &
      vfields%u_exact = [(run%problem%u_exact%value(mesh%xy(1, i), mesh%xy(2, i)), i=1, mesh%nnode)]
    vfields%contact = vtk_contact_status(res%bound_kind, res%bound, res%u, contact_rel_tol)
    if (res%has_dual) then
      if (run%problem%kind == PROBLEM_P1 .and. allocated(res%q_hdiv)) then
        ! the RT1 field (discontinuous tangential part) per triangle, as for P2
        allocate (vfields%lambda_centroid(2, mesh%ntri), vfields%lambda_vertices(6, mesh%ntri), stat=ist)
        if (alloc_failed(ist, st, 'the dual field for ParaView', 8 * mesh%ntri, BYTES_REAL)) return
        do j = 1, mesh%ntri
          vfields%lambda_centroid(:, j) = hdiv_point_value(mesh, res%q_hdiv, j, [1.0_dp, 1.0_dp, 1.0_dp] / 3.0_dp)
          do i = 1, 3
            vfields%lambda_vertices(2 * i - 1:2 * i, j) = hdiv_point_value(mesh, res%q_hdiv, j, &
              merge(1.0_dp, 0.0_dp, [1, 2, 3] == i))
          end do
        end do
      else if (run%problem%kind == PROBLEM_P1) then
        vfields%q_h = reshape(res%q, [2, mesh%nnode])
      else
        ! lambda^h at the centroid and, from inside the triangle, at its three vertices
        allocate (vfields%lambda_centroid(2, mesh%ntri), vfields%lambda_vertices(6, mesh%ntri), stat=ist)
        if (alloc_failed(ist, st, 'the dual field for ParaView', 8 * mesh%ntri, BYTES_REAL)) return
        do j = 1, mesh%ntri
          vfields%lambda_centroid(:, j) = dual_p2_lambda(res%lambda, mesh, run%problem%f, j, &
                                                         [1.0_dp, 1.0_dp, 1.0_dp] / 3.0_dp)
          do i = 1, 3
            vfields%lambda_vertices(2 * i - 1:2 * i, j) = dual_p2_lambda(res%lambda, mesh, run%problem%f, j, &
              merge(1.0_dp, 0.0_dp, [1, 2, 3] == i))
          end do
        end do
      end if
      vfields%est_element = res%est_elem
      if (allocated(mesh%tri_gen)) vfields%depth = mesh%tri_gen
      vfields%est = res%est
      vfields%has_est = .true.
    end if
    call vtk_write_level(vtk_level_path(run%cfg%output, res%level), mesh, res%level, res%h, res%u, vfields, st, &
                         run%cfg%vtu_format)
  end subroutine vtk_level

  !> The header of the error table: what was solved, what ran, the bounds' meaning, the
  !> exact energy when known, and the resolved namelist.
  function table_header(run, mesh) result(header)
    type(run_t), intent(in) :: run
    type(mesh_t), intent(in) :: mesh
    character(len=:), allocatable :: header(:)
    character(len=500), allocatable :: head(:)
    character(len=:), allocatable :: echo(:)
    type(run_config_t) :: resolved
    character(len=:), allocatable :: norm_name, parts, what
    character(len=500) :: line
    integer :: k, w
    associate (cfg => run%cfg, scene => run%scene, q0 => run%q0)
      if (scene%problem == PROBLEM_P1) then
        norm_name = 'the full H1 norm ||.||_1'
      else
        norm_name = 'the H1 seminorm |.|_1'
      end if
      parts = parts_run(run)
      if (cfg%has_problem) then
        what = 'problem: ' // trim(scene%description)
      else
        what = 'scene ' // trim(scene%name) // ': ' // trim(scene%description)
      end if
      head = [character(len=500) :: &
        'dualsig error table: ' // run%title, &
        what, &
        'problem P' // itoa(scene%problem) // '; err_u_H1 is ' // norm_name // ' of u - u_h (the energy norm)', &
        parts, &
        'coarse mesh: ' // itoa(q0%nnode) // ' nodes, ' // itoa(q0%ntri) // ' triangles, ' // &
          itoa(q0%nloop) // ' boundary loop(s), min angle ' // rtoa(q0%min_angle_deg) // &
          ' deg, max side ratio in a triangle ' // rtoa(q0%max_tri_side_ratio) // &
          ' (uniform refinement keeps both)', &
        'h = longest side; ndof = unknowns not fixed by Gamma_u; primal_s = wall time of the ' // &
          'solve; rates = observed orders between levels']
      if (run%adaptive) then
        line = 'adaptive: level = step of solve -> estimate -> mark (Doerfler, theta = ' // rtoa(cfg%adapt_theta) // &
          ', on est_element) -> refine (newest-vertex bisection, conforming closure); rates in ndof^(-1/2), ' // &
          'rate_est_ndof = p in sqrt(est) ~ ndof^(-p); rel_cert = sqrt(est / energy_lo)'
        head = [character(len=500) :: head, line]
        line = 'adaptive: smallest angle over all steps ' // rtoa(run%min_angle) // ' deg; refine_s = marking, ' // &
          'bisection and transfer of u_h; estimate_s = dual solve and bounds; elapsed_s = since the start; ' // &
          'nheld = triangles left unmarked at the size floor of double precision'
        head = [character(len=500) :: head, line]
        line = 'adaptive: the marks are Doerfler''s set extended by the largest indicators until a step''s new ' // &
          'nodes reach (min_growth - 1) ndof, min_growth = ' // rtoa(cfg%adapt_min_growth) // ' (a target: a few ' // &
          'bisections are tried, then the step is kept); a step that can reach tol ' // &
          'aims at it: between 1 and ' // rtoa(adapt_aim_margin) // ' times (rel/tol)^(1/p) ndof, p the last rate ' // &
          '(at most ' // rtoa(adapt_aim_rate_max) // ')'
        head = [character(len=500) :: head, line]
        if (allocated(run%stop_text)) then
          line = 'adaptive loop STOPPED at ' // run%stop_text
          head = [character(len=500) :: head, line]
        end if
      end if
      if (cfg%dual_enabled) then
        if (scene%problem == PROBLEM_P1) then
          line = 'est = E(q_h, u_h) of (6.13) >= ||u - u_h||_1^2; eff = sqrt(est) / err_u_H1; err_q_Q = ' // &
            '(err_q_L2^2 + err_lambda3^2)^(1/2), err_q_L2 = ||q - grad u||, err_lambda3 = ||f + div q - u||; ' // &
            'energy_lo <= ||u||_1^2 = (f,u) <= energy_hi (6.14)'
        else
          line = 'est = E(lambda_h, u_h) of (6.26) >= |u - u_h|_1^2; eff = sqrt(est) / err_u_H1; err_q_Q = ' // &
            '||grad u - lambda_h||_0; energy_lo <= |u|_1^2 = (f,u) <= energy_hi (Theorem 6.4)'
        end if
        head = [character(len=500) :: head, line]
        line = 'certified = 1: est, energy_lo and energy_hi are guaranteed for the given f (f enters only through ' // &
          'its per-triangle integrals, converged to 1e-12; other integrals exact); 0: not guaranteed (see warnings)'
        head = [character(len=500) :: head, line]
        line = 'sqrt_est = sqrt(est), the guaranteed bound of the energy norm of u - u_h; cert_rel_err = ' // &
          'sqrt(est / energy_lo) >= that norm relative to the norm of u (certified rows only)'
        head = [character(len=500) :: head, line]
        if (scene%problem /= PROBLEM_P1 .and. cfg%dual_particular == 'polynomial') then
          line = 'lambda_h piecewise quadratic with div lambda_h = -Pi_1 f (L2 projection onto linears on each T); ' // &
            'f - Pi_1 f enters est and energy_hi as (h_T/pi) ||f - Pi_1 f||_T per triangle (Payne-Weinberger)'
          head = [character(len=500) :: head, line]
        end if
        if (scene%has_exact) then
          line = 'exact energy (f, u) = ' // rtoa(exact_energy(mesh, scene%u, scene%grad_u, tri_rule(exact_degree), &
            scene%problem == PROBLEM_P1))
          head = [character(len=500) :: head, line]
        end if
      end if
      head = [character(len=500) :: head, 'namelist (resolved):']
      resolved = cfg
      if (.not. run%by_names) then                       ! by name: the echo keeps the names
        resolved%gamma_u_markers = 0
        resolved%gamma_a_markers = 0
        k = min(size(run%problem%gamma_u), size(resolved%gamma_u_markers))
        resolved%gamma_u_markers(1:k) = run%problem%gamma_u(1:k)
        k = min(size(run%problem%gamma_a), size(resolved%gamma_a_markers))
        resolved%gamma_a_markers(1:k) = run%problem%gamma_a(1:k)
      end if
      echo = config_echo(resolved)
      if (run%nonconverged > 0) then
        write (line, '(a,i0,a)') 'WARNING: ', run%nonconverged, ' solve(s) stopped at max_iter (see kkt_residual)'
        echo = [character(len=len(echo)) :: echo, line]
      end if
      if (run%uncertified > 0) then
        write (line, '(a,i0,a)') 'WARNING: ', run%uncertified, ' level(s) with bounds that are NOT certified ' // &
          '(column certified = 0; see the warnings of the run)'
        echo = [character(len=len(echo)) :: echo, line]
      end if
      ! lines as long as the longest (an expression of &problem may be longer than 300)
      w = max(len(head), len(echo))
      allocate (character(len=w) :: header(size(head) + size(echo)))   ! small: the header lines
      do k = 1, size(head)
        header(k) = head(k)
      end do
      do k = 1, size(echo)
        header(size(head) + k) = echo(k)
      end do
    end associate
  end function table_header

  !> The "parts run" line of the header: which computations the run made.
  function parts_run(run) result(parts)
    type(run_t), intent(in) :: run
    character(len=:), allocatable :: parts
    character(len=:), allocatable :: matrices, dual_method
    associate (cfg => run%cfg, scene => run%scene)
      matrices = trim(merge('K + M             ', 'K (no mass matrix)', scene%problem == PROBLEM_P1))
      if (cfg%method == 'active_set') then
        parts = 'parts run: mesh, assembly (' // matrices // '), primal solve (primal-dual active set, CHOLMOD, ' // &
          'ordering ' // trim(cfg%dual_ordering) // ')'
      else if (cfg%method == 'multigrid') then
        parts = 'parts run: mesh, assembly (' // matrices // '), primal solve (multigrid: truncated nonsmooth ' // &
          'Newton multigrid on the hierarchy of the uniform refinements, on a level without one on a ' // &
          'smoothed-aggregation hierarchy (multigrid_amg); the method of each level in the level reports)'
      else if (cfg%method == 'schur' .or. cfg%method == 'auto') then
        parts = 'parts run: mesh, assembly (' // matrices // '), primal solve (' // trim(cfg%method) // ': '
        if (cfg%method == 'auto') parts = parts // 'above ' // itoa(mg_auto_min_unknowns) // ' unknowns truncated ' // &
          'nonsmooth Newton multigrid (the refinement hierarchy, or a smoothed-aggregation one on a level ' // &
          'without it), else '
        parts = parts // 'one CHOLMOD factorisation, exact QP on the Schur complement of the bounded unknowns'
        if (cfg%method == 'auto') parts = parts // ' when at most ' // itoa(boundary_schur_max_default) // &
          ', else primal-dual active set; the method of each level in the level reports'
        parts = parts // '; ordering ' // trim(cfg%dual_ordering) // ')'
      else
        parts = 'parts run: mesh, assembly (' // matrices // '), primal solve (projected SOR'
        if (cfg%omega_auto) parts = parts // ', omega from a Lanczos estimate'
        parts = parts // ')'
      end if
      if (scene%has_exact) then
        parts = parts // ', exact errors (degree-' // itoa(exact_degree) // ' quadrature)'
      else
        parts = parts // ', no exact solution: no error columns (nan in the CSV)'
      end if
      dual_method = trim(cfg%dual_method)
      if (dual_method == 'default') dual_method = trim(merge('active_set', 'default   ', scene%problem == PROBLEM_P1))
      if (cfg%dual_enabled .and. scene%problem == PROBLEM_P1 .and. cfg%dual_space == 'hdiv' .and. &
          cfg%dual_method == 'default') then
        parts = parts // '; dual analysis: space hdiv (RT1 fields, q.nu >= 0 at boundary edge ends), active_set ' // &
          'with a CHOLMOD factorisation on the first level, nested (multigrid-preconditioned CG from the ' // &
          'previous level''s field) on uniformly refined levels; bounds (6.13), (6.14) from the feasible q'
      else if (cfg%dual_enabled .and. scene%problem == PROBLEM_P1 .and. cfg%dual_space == 'hdiv') then
        parts = parts // '; dual analysis: space hdiv (RT1 fields, q.nu >= 0 at boundary edge ends), ' // dual_method // &
          '; bounds (6.13), (6.14) from the feasible q'
      else if (cfg%dual_enabled .and. scene%problem == PROBLEM_P1) then
        parts = parts // '; dual analysis: space paper (continuous P1 vector fields), ' // dual_method // &
          ' with a CHOLMOD factorisation; bounds (6.13), (6.14) from the feasible q'
      else if (cfg%dual_enabled) then
        if (dual_method == 'default') then
          parts = parts // '; dual analysis: equilibrium elements, multigrid (the stream function, no ' // &
            'factorisation) from level 2 on of a uniform refinement and on meshes of ' // itoa(mg_auto_min_unknowns) // &
            ' nodes or more, ' // &
            'augmented (inner solver ' // trim(cfg%dual_inner) // ') on smaller meshes and domains with holes'
        else
          parts = parts // '; dual analysis: equilibrium elements, ' // dual_method
        end if
        if (dual_method == 'augmented') parts = parts // ' (inner solver ' // trim(cfg%dual_inner) // ')'
        parts = parts // '; lambda^h = lambda^f + q^h admissible; bounds (6.26), Theorem 6.4'
      else
        parts = parts // '; dual analysis not requested'
      end if
    end associate
  end function parts_run

  !> Write the tables of the first `nlevel` levels (and the LaTeX table and the ParaView
  !> collection on request) under temporary names, every write checked, then commit them
  !> together with the level files (file_commit_all): on any failure none of them is left
  !> and earlier files of the same names are kept.  A non-empty `stopped` (why the run
  !> stopped after level nlevel) becomes a header line of the text table.
  subroutine write_run_files(run, mesh, tab, nlevel, stopped, st, unit)
    type(run_t), intent(in) :: run
    type(mesh_t), intent(in) :: mesh
    type(table_t), intent(in) :: tab
    integer, intent(in) :: nlevel
    character(len=*), intent(in) :: stopped
    type(status_t), intent(out) :: st
    integer, intent(in) :: unit
    character(len=:), allocatable :: txt_path, csv_path, tex_path
    character(len=len_trim(run%cfg%output) + 16), allocatable :: paths(:)
    character(len=:), allocatable :: header(:)
    character(len=300) :: line
    integer :: nstale
    associate (cfg => run%cfg)
      txt_path = trim(cfg%output) // '.txt'
      csv_path = trim(cfg%output) // '.csv'
      tex_path = trim(cfg%output) // '.tex'
      header = table_header(run, mesh)
      if (len(stopped) > 0) then
        if (run%adaptive) then
          line = 'STOPPED after step ' // itoa(nlevel) // ': ' // stopped
        else
          line = 'STOPPED after level ' // itoa(nlevel) // ' of ' // itoa(max_rows(cfg)) // ': ' // stopped
        end if
        header = [character(len=len(header)) :: header(1:1), line, header(2:)]
      end if
      ! (element by element: gfortran 12 corrupts the heap on some constructors of strings)
      allocate (paths(2 + merge(1, 0, cfg%latex) + merge(1, 0, run%adaptive) + merge(nlevel + 1, 0, cfg%vtk)))  ! small: files
      paths(1) = txt_path
      paths(2) = csv_path
      if (cfg%latex) paths(3) = tex_path
      if (run%adaptive) paths(3 + merge(1, 0, cfg%latex)) = mesh_edges_path(cfg%output)
      if (cfg%vtk) paths(size(paths) - nlevel:) = vtk_run_files(cfg%output, nlevel)
      call table_write_text(tab, txt_path, header, st)
      if (st%code == 0) call table_write_csv(tab, csv_path, st)
      if (st%code == 0 .and. cfg%latex) call table_write_latex(tab, tex_path, run%title, st)
      if (st%code == 0 .and. cfg%vtk) call vtk_write_collection(cfg%output, nlevel, st)
      if (st%code == 0 .and. run%adaptive) call mesh_edges_write(mesh_edges_path(cfg%output), mesh, st)
      if (st%code == 0) call file_commit_all(paths, st)
      if (st%code /= 0) then
        st%msg = run%where // ': ' // st%msg
        call file_delete(temp_name(txt_path))
        call file_delete(temp_name(csv_path))
        call file_delete(temp_name(tex_path))
        if (run%adaptive) call file_delete(temp_name(mesh_edges_path(cfg%output)))
        if (cfg%vtk) call vtk_discard_run(cfg%output, max_rows(cfg))
        return
      end if
      write (unit, '(a)') 'dualsig: table written to ' // txt_path // ' and ' // csv_path
      if (cfg%latex) write (unit, '(a)') 'dualsig: LaTeX table written to ' // tex_path
      if (run%adaptive) write (unit, '(a)') 'dualsig: final mesh written to ' // mesh_edges_path(cfg%output) // &
        ' (gnuplot: plot ''' // mesh_edges_path(cfg%output) // ''' with lines; make plots)'
      if (cfg%vtk) write (unit, '(a)') 'dualsig: ParaView files written: ' // trim(cfg%output) // &
        '.pvd and ' // itoa(nlevel) // ' level file(s) ' // trim(cfg%output) // '_levelLL.vtu'
      if (cfg%vtk) call vtk_remove_stale(cfg%output, nlevel, nstale)
      if (cfg%vtk .and. nstale > 0) write (unit, '(a)') 'dualsig: removed ' // itoa(nstale) // &
        ' level file(s) ' // trim(cfg%output) // '_levelLL.vtu of an earlier run with more levels'
      if (run%nonconverged > 0) call set_warning(st, DS_WARN_NOT_CONVERGED, &
        itoa(run%nonconverged) // ' solve(s) of run "' // trim(run_name(cfg)) // '" did not converge')
      if (run%uncertified > 0) call set_warning(st, DS_WARN_NOT_CERTIFIED, &
        itoa(run%uncertified) // ' level(s) of run "' // trim(run_name(cfg)) // '" have bounds that are NOT certified')
    end associate
  end subroutine write_run_files

  !> A certified relative error as printed: 'none (...)' for huge (no certified step with a
  !> useful lower energy bound).
  function rel_text(rel) result(text)
    real(dp), intent(in) :: rel
    character(len=:), allocatable :: text
    if (rel >= huge(1.0_dp)) then
      text = 'none (no certified step with a positive lower energy bound)'
    else
      text = rtoa(rel)
    end if
  end function rel_text

  !> The name of a run in messages: its title, or its output name when it has none.
  pure function run_name(cfg) result(name)
    type(run_config_t), intent(in) :: cfg
    character(len=:), allocatable :: name
    name = trim(cfg%title)
    if (len(name) == 0) name = trim(cfg%output)
  end function run_name

  !> Fail early, before any computation, when the tables of run `cfg` cannot be written:
  !> create the output's directory (like mkdir -p), refuse an output whose table name is a
  !> directory, and create and delete the temporary file of the text table there.  Errors
  !> name the namelist file, the &run output item and the directory.
  subroutine check_output_writable(cfg, st)
    type(run_config_t), intent(in) :: cfg
    type(status_t), intent(out) :: st
    character(len=:), allocatable :: txt_path, dir, where
    type(text_file_t) :: probe
    integer :: k
    logical :: is_dir
    txt_path = trim(cfg%output) // '.txt'
    dir = dir_of(txt_path, index(txt_path, '/', back=.true.))
    where = cfg%source_file // ': run of line ' // itoa(cfg%line) // ": &run output = '" // &
      trim(cfg%output) // "': "
    call ensure_parent_dir(txt_path, st)
    if (st%code /= 0) then
      st%msg = where // st%msg // " (expected a writable directory '" // dir // "' or one that can be created)"
      return
    end if
    do k = 1, 2
      inquire (file=trim(cfg%output) // merge('.txt/.', '.csv/.', k == 1), exist=is_dir)
      if (is_dir) then
        call set_error(st, DS_ERR_IO, where // trim(cfg%output) // merge('.txt', '.csv', k == 1) // &
          ' is a directory (expected a path for the table files, without extension)')
        return
      end if
    end do
    call check_output_not_input(cfg, where, st)
    if (st%code /= 0) return
    call text_open(probe, txt_path, st)
    if (st%code /= 0) then
      st%msg = where // "cannot create files in the directory '" // dir // "' (" // st%msg // &
        '; expected a writable directory)'
      return
    end if
    call text_abandon(probe)
  end subroutine check_output_writable

  !> The &mesh items given (different from their defaults) that the mesh source does not
  !> use, as 'x0, nx' ('' when none): the generator's box and counts for a file or the
  !> L-shape, n for the rectangle, file and format for the generators.
  function mesh_items_ignored(cfg, defaults) result(s)
    type(run_config_t), intent(in) :: cfg, defaults
    character(len=:), allocatable :: s
    logical :: box, count_n, file
    box = trim(cfg%mesh_source) /= 'rectangle'
    count_n = trim(cfg%mesh_source) == 'rectangle' .or. trim(cfg%mesh_source) == 'file'
    file = trim(cfg%mesh_source) /= 'file'
    s = ''
    if (box .and. cfg%x0 /= defaults%x0) s = s // ', x0'
    if (box .and. cfg%x1 /= defaults%x1) s = s // ', x1'
    if (box .and. cfg%y0 /= defaults%y0) s = s // ', y0'
    if (box .and. cfg%y1 /= defaults%y1) s = s // ', y1'
    if (box .and. cfg%nx /= defaults%nx) s = s // ', nx'
    if (box .and. cfg%ny /= defaults%ny) s = s // ', ny'
    if (box .and. cfg%pattern /= defaults%pattern) s = s // ', pattern'
    if (count_n .and. cfg%n /= defaults%n) s = s // ', n'
    if (file .and. cfg%mesh_file /= defaults%mesh_file) s = s // ', file'
    if (file .and. cfg%mesh_format /= defaults%mesh_format) s = s // ', format'
    if (len(s) > 0) s = s(3:)
  end function mesh_items_ignored

  !> Two runs of a batch must not have the same output: the later run would replace the
  !> earlier one's files.  The same name in the same directory (the directories exist after
  !> check_output_writable; compared by same_file, so 'out/x' and './out/x' are the same).
  subroutine check_distinct_outputs(runs, st)
    type(run_config_t), intent(in) :: runs(:)
    type(status_t), intent(inout) :: st
    integer :: r, s
    do r = 2, size(runs)
      do s = 1, r - 1
        if (.not. same_output(runs(s)%output, runs(r)%output)) cycle
        call set_error(st, DS_ERR_INPUT, runs(r)%source_file // ': run of line ' // itoa(runs(r)%line) // &
          ": &run output = '" // trim(runs(r)%output) // "' is also the output of the run of line " // &
          itoa(runs(s)%line) // ' (expected a different output name for every run of a batch: ' // &
          "the later run would replace the earlier one's files)")
        return
      end do
    end do
  end subroutine check_distinct_outputs

  !> True when the output names a and b give the same files: the same last component in
  !> the same directory.
  logical function same_output(a, b)
    character(len=*), intent(in) :: a, b
    integer :: ka, kb
    ka = index(trim(a), '/', back=.true.)
    kb = index(trim(b), '/', back=.true.)
    same_output = trim(a(ka + 1:)) == trim(b(kb + 1:))
    if (same_output) same_output = same_file(dir_of(a, ka), dir_of(b, kb))
  end function same_output

  !> The directory part of the output name `name` whose last '/' is at k ('.' without one).
  function dir_of(name, k) result(dir)
    character(len=*), intent(in) :: name
    integer, intent(in) :: k
    character(len=:), allocatable :: dir
    if (k == 0) then
      dir = '.'
    else if (k == 1) then
      dir = '/'
    else
      dir = name(1:k - 1)
    end if
  end function dir_of

  !> An output file of run cfg (the tables, the ParaView series, the final mesh) must not be
  !> one of its input files (the namelist file, the mesh file, f_file): writing it would
  !> destroy the input (same_file: the same device and inode, whatever the spelling).
  subroutine check_output_not_input(cfg, where, st)
    type(run_config_t), intent(in) :: cfg
    character(len=*), intent(in) :: where
    type(status_t), intent(inout) :: st
    type(path_t) :: inputs(3), outputs(5)
    integer :: i, o
    inputs(1)%s = cfg%source_file
    inputs(2)%s = ''
    if (trim(cfg%mesh_source) == 'file') inputs(2)%s = trim(cfg%mesh_file)
    inputs(3)%s = ''
    if (allocated(cfg%f_file)) inputs(3)%s = trim(config_text(cfg%f_file))
    outputs(1)%s = trim(cfg%output) // '.txt'
    outputs(2)%s = trim(cfg%output) // '.csv'
    outputs(3)%s = trim(cfg%output) // '.tex'
    outputs(4)%s = trim(cfg%output) // '.pvd'
    outputs(5)%s = mesh_edges_path(cfg%output)
    do i = 1, size(inputs)
      if (len(inputs(i)%s) == 0) cycle
      do o = 1, size(outputs)
        if (same_file(outputs(o)%s, inputs(i)%s)) call refuse(outputs(o)%s, inputs(i)%s)
        if (.not. is_ok(st)) return
      end do
      ! the ParaView files of the levels (or adaptive steps) the run may write
      do o = 1, merge(max_rows(cfg), 0, cfg%vtk)
        if (same_file(vtk_level_path(cfg%output, o), inputs(i)%s)) call refuse(vtk_level_path(cfg%output, o), inputs(i)%s)
        if (.not. is_ok(st)) return
      end do
    end do

  contains

    subroutine refuse(output, input)
      character(len=*), intent(in) :: output, input
      call set_error(st, DS_ERR_IO, where // 'the output file ' // output // ' is the input file ' // &
        input // ' of this run (expected an output name that does not overwrite the namelist, mesh ' // &
        'or load file)')
    end subroutine refuse
  end subroutine check_output_not_input

end module dualsig_driver
