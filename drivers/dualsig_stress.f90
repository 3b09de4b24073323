!> dualsig_stress: the numerical stability stress suite (`make stress`).
!>
!> Every case solves a Signorini problem in a hostile setting and checks an expectation:
!> - mesh quality: needles (smallest angle 2 and 0.5 degrees), a conforming mesh graded
!>   towards a corner (size ratio > 10^3), a 1:1000 domain (with square and with needle
!>   cells), a family that violates the alpha-beta regularity on purpose (angles -> 0).
!>   Expected: the solvers converge, est >= err^2 (the bound stays guaranteed), the energy
!>   bounds bracket (f,u), and mesh_quality flags the mesh;
!> - scaling: f times s = 1e-8 .. 1e8 (P1 and P2) and the domain times L = 1e-4 .. 1e4 (P2
!>   only: -Lap u + u = f has no length-scale invariance).  Expected: relative errors and
!>   effectivities equal to those of s = L = 1 within scale_tol = 1e-8;
!> - contact extremes: everything in contact, nothing in contact, a contact set that
!>   changes at every level, the contact/separation transition exactly on a node;
!> - parameters at the edge: omega -> 0 and omega -> 2 (and omega = 0, 2 rejected), Uzawa with
!>   rho far too large (a quick error with a message), an automatic rho that is too large
!>   (divergence detected, safe retry), iteration limits (reported as not converged with
!>   DS_WARN_NOT_CONVERGED, never a silent "converged");
!> - size: the largest mesh (`--max-level`, default 10: 1.05e6 unknowns), each size case in
!>   its own process so that its peak memory (VmHWM of /proc/self/status) is its own;
!> - floating point: est >= 0 and the energy bounds ordered under catastrophic cancellation
!>   (Remark 6.1: est is summed from non-negative terms), zero load (0/0 in relative
!>   residuals), and no NaN or Inf in any result vector (checked after every solve).
!>
!> Usage: dualsig_stress [--max-level N] [--quick] [--out DIR]
!>   --max-level N  finest level of the size cases (default 10; level l has (2^l+1)^2 nodes)
!>   --quick        smaller meshes everywhere (development; the table says so)
!>   --out DIR      directory of stress.txt and stress.md (default out)
!> Exit status: 0 all cases PASS, 1 some case FAILed (after writing the tables), 2 usage
!> or output error.
program dualsig_stress
  use, intrinsic :: iso_fortran_env, only: output_unit, error_unit
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use dualsig_kinds, only: dp
  use dualsig_clock, only: wall_seconds, peak_memory_mb
  use dualsig_status, only: status_t, is_ok, DS_OK, DS_WARN_NOT_CONVERGED, DS_ERR_INPUT, DS_ERR_NUMERIC
  use dualsig_mesh, only: mesh_t
  use dualsig_mesh_generate, only: mesh_rectangle
  use dualsig_mesh_distort, only: mesh_corner_graded
  use dualsig_mesh_refine, only: mesh_refine_uniform, mesh_prolongate_p1
  use dualsig_mesh_quality, only: mesh_quality_t, mesh_quality
  use dualsig_quadrature, only: tri_rule
  use dualsig_solver_psor, only: psor_settings_t, psor_result_t, psor_solve
  use dualsig_qp_types, only: BOUND_FIXED, BOUND_LOWER
  use dualsig_solver_active_set, only: active_set_settings_t, active_set_result_t, active_set_solve
  use dualsig_solver_uzawa, only: uzawa_settings_t, uzawa_result_t, uzawa_solve
  use dualsig_qp_types, only: ROW_INEQUALITY
  use dualsig_spd_solver, only: cholmod_spd_t, block_diag_spd_t
  use dualsig_sparse, only: csr_t, rect_t, rect_from_triplets
  use dualsig_problem_primal, only: primal_system_t, primal_assemble, primal_constraints
  use dualsig_problem_kinds, only: PROBLEM_P1
  use dualsig_scenes, only: scene_t, scene_lookup
  use dualsig_stress_problems, only: stress_problem, stress_scaled_scene
  use dualsig_estimate_errors, only: exact_energy
  use dualsig_assembly_dual_p1, only: assemble_dual_p1
  use dualsig_problem_dual_p1, only: dual_p1_settings_t, dual_p1_result_t, dual_p1_solve, &
                                     dual_p1_constraint_rows
  use dualsig_scene_problem, only: analysis_problem_set_scene
  use dualsig_analysis, only: analysis_problem_t, analysis_settings_t, analysis_t, level_result_t, &
                              analysis_start, analysis_next_level
  use dualsig_io_files, only: temp_name, file_commit, ensure_parent_dir
  use dualsig_strings, only: itoa
  implicit none

  ! ---- expectations (named, see doc/stress.md)
  real(dp), parameter :: scale_tol = 1.0e-8_dp       !! scaling: |ratio - 1| of relative errors and effectivities
  real(dp), parameter :: bound_slack = 1.0e-10_dp    !! est >= err^2 (1 - slack): err^2 and est are two quadratures
  real(dp), parameter :: energy_slack = 1.0e-10_dp   !! lo <= (f,u) <= hi up to slack * |(f,u)| (quadrature)
  real(dp), parameter :: order_ulps = 64.0_dp        !! energy_lo <= energy_hi + order_ulps eps |energy_hi|
  real(dp), parameter :: tol = 1.0e-10_dp            !! KKT tolerance of the iterative solves
  real(dp), parameter :: omega_ref_tol = 1.0e-6_dp   !! omega extremes: ||u - u_active_set|| / ||u||
  integer, parameter :: quick_divergence_iters = 20  !! rho far too large: the error must come within this
  integer, parameter :: max_rows = 80
  !> Active-set changes allowed in the primal solves (the batch driver passes its max_iter,
  !> default 200000; the library default of 100 is reached on needle meshes)
  integer, parameter :: active_set_max_iter = 100000
  integer, parameter :: exact_degree = 16, load_degree = 5

  type :: row_t
    character(len=28) :: name = ''
    character(len=34) :: varied = ''
    logical :: conv = .false.
    integer :: iters = 0
    real(dp) :: kkt = -1.0_dp        !! < 0: not applicable
    real(dp) :: dual_res = -1.0_dp
    real(dp) :: err = -1.0_dp
    real(dp) :: sqrt_est = -1.0_dp
    real(dp) :: eff = -1.0_dp
    real(dp) :: seconds = 0.0_dp
    logical :: pass = .false.
    character(len=120) :: check = ''
  end type row_t

  !> What one level of a case produced.
  type :: level_t
    integer :: code = DS_OK                !! status of the primal solve
    integer :: dual_code = DS_OK           !! status of the dual solve
    character(len=200) :: msg = ''
    logical :: conv = .false., dual_conv = .false., dual_ran = .false.
    logical :: finite = .true.             !! every result vector and number finite
    integer :: iters = 0, dual_iters = 0, ncontact = 0, nbounded = 0, ndof = 0
    real(dp) :: kkt = 0.0_dp, dual_res = 0.0_dp, err = 0.0_dp, err_l2 = 0.0_dp
    real(dp) :: est = 0.0_dp, lo = 0.0_dp, hi = 0.0_dp, energy = 0.0_dp, seconds = 0.0_dp, h = 0.0_dp
  end type level_t

  type(row_t) :: rows(max_rows)
  integer :: nrows = 0
  integer :: max_level = 10
  logical :: quick = .false.
  character(len=256) :: out_dir = 'out', self_path = ''
  real(dp) :: t_start

  call parse_args()
  t_start = wall_seconds()
  if (quick) write (*, '(a)') 'dualsig_stress: --quick (smaller meshes)'
  write (*, '(a)') 'dualsig_stress: running the stress cases'
  call cases_mesh_quality()
  call cases_scaling()
  call cases_contact()
  call cases_parameters()
  call cases_floating_point()
  call cases_size()
  call write_tables()

contains

  ! ================================================================== arguments
  subroutine parse_args()
    integer :: k, n, ios
    character(len=256) :: arg, val
    call get_command_argument(0, self_path)
    n = command_argument_count()
    k = 1
    do while (k <= n)
      call get_command_argument(k, arg)
      select case (trim(arg))
      case ('--quick')
        quick = .true.
      case ('--max-level', '--out', '--size-child')
        if (k == n) call usage('missing value after ' // trim(arg))
        call get_command_argument(k + 1, val)
        if (trim(arg) == '--max-level') then
          read (val, *, iostat=ios) max_level
          if (ios /= 0 .or. max_level < 2 .or. max_level > 13) call usage('--max-level expects an integer in 2..13')
        else if (trim(arg) == '--out') then
          out_dir = val
        else
          call size_child(trim(val))     ! internal: one size case in this process, then stop
        end if
        k = k + 1
      case default
        call usage('unknown argument ' // trim(arg))
      end select
      k = k + 1
    end do
  end subroutine parse_args

  subroutine usage(msg)
    character(len=*), intent(in) :: msg
    write (error_unit, '(a)') 'dualsig_stress: ' // msg
    write (error_unit, '(a)') 'usage: dualsig_stress [--max-level N] [--quick] [--out DIR]'
    stop 2
  end subroutine usage

  ! ================================================================== one level of a case
  !> One level of the analysis pipeline (dualsig_analysis) for `scene` on `mesh` from the
  !> start u (zero when not allocated; the solution on return): primal solve, errors,
  !> and the dual analysis and bounds when `dual`.  method: 'active_set' (default) or
  !> 'psor' (omega, max_iter).  Every result is checked for NaN/Inf.
  subroutine solve_level(mesh, scene, u, o, dual, method, omega, max_iter)
    type(mesh_t), intent(in) :: mesh
    type(scene_t), intent(in) :: scene
    real(dp), allocatable, intent(inout) :: u(:)
    type(level_t), intent(out) :: o
    logical, intent(in) :: dual
    character(len=*), intent(in), optional :: method
    real(dp), intent(in), optional :: omega
    integer, intent(in), optional :: max_iter
    type(analysis_settings_t) :: set
    type(analysis_t) :: an
    type(level_result_t) :: res
    type(status_t) :: st
    set = stress_settings(1, dual, method, omega, max_iter)
    if (.not. allocated(u)) allocate (u(mesh%nnode), source=0.0_dp)
    call analysis_start(an, stress_analysis_problem(mesh, scene), set, st, u_start=u)
    if (is_ok(st)) call analysis_next_level(an, res, st)
    call level_from_result(an, scene, res, st, o)
    if (allocated(res%u)) u = res%u
  end subroutine solve_level

  !> The analysis problem of a stress case: the scene's load, exact solution and boundary parts.
  function stress_analysis_problem(mesh, scene) result(pb)
    type(mesh_t), intent(in) :: mesh
    type(scene_t), intent(in) :: scene
    type(analysis_problem_t) :: pb
    pb%mesh = mesh
    call analysis_problem_set_scene(pb, scene)
  end function stress_analysis_problem

  !> The analysis settings of the stress cases: the library solvers' own defaults (AMD,
  !> dual tolerance 1e-10 on every level), KKT tolerance `tol`, the dual fields kept for the
  !> finiteness checks.
  function stress_settings(levels, dual, method, omega, max_iter) result(set)
    integer, intent(in) :: levels
    logical, intent(in) :: dual
    character(len=*), intent(in), optional :: method
    real(dp), intent(in), optional :: omega
    integer, intent(in), optional :: max_iter
    type(analysis_settings_t) :: set
    set%levels = levels
    set%tol = tol
    set%method = 'active_set'
    set%max_iter = active_set_max_iter
    if (present(method)) then
      if (method == 'psor') then
        set%method = 'psor'
        set%omega = 1.0_dp
        if (present(omega)) set%omega = omega
        set%max_iter = 1000000
      end if
    end if
    if (present(max_iter)) set%max_iter = max_iter
    set%dual = dual
    set%dual_tol_h2 = 0.0_dp
    set%keep_fields = .true.
  end function stress_settings

  !> What a level of the pipeline produced, in the stress suite's terms; st is the
  !> level's status (an error of the primal or of the dual solve).
  subroutine level_from_result(an, scene, res, st, o)
    type(analysis_t), intent(in) :: an
    type(scene_t), intent(in) :: scene
    type(level_result_t), intent(in) :: res
    type(status_t), intent(in) :: st
    type(level_t), intent(out) :: o
    logical :: primal_done
    primal_done = allocated(res%u)
    o%h = res%h
    o%ndof = res%ndof
    o%iters = res%primal_iters
    o%kkt = res%kkt_residual
    o%seconds = res%primal_seconds + res%dual_seconds
    o%code = merge(DS_WARN_NOT_CONVERGED, DS_OK, res%primal_limit)
    if (.not. primal_done .and. .not. is_ok(st)) o%code = st%code
    if (allocated(st%msg)) o%msg = st%msg
    o%conv = primal_done .and. .not. res%primal_limit
    if (.not. primal_done) then
      o%finite = ieee_is_finite(o%kkt)
      return
    end if
    o%finite = all_finite(res%u) .and. ieee_is_finite(o%kkt)
    o%nbounded = count(res%bound_kind == BOUND_LOWER)
    o%ncontact = count(res%bound_kind == BOUND_LOWER .and. res%u <= res%bound)
    o%err_l2 = res%err_l2
    o%err = res%err_energy
    o%energy = exact_energy(an%mesh, scene%u, scene%grad_u, tri_rule(exact_degree), scene%problem == PROBLEM_P1)
    o%finite = o%finite .and. ieee_is_finite(o%err) .and. ieee_is_finite(o%energy)
    if (.not. an%settings%dual) return
    o%dual_ran = .true.
    o%dual_code = merge(DS_WARN_NOT_CONVERGED, DS_OK, res%dual_limit)
    if (.not. is_ok(st)) o%dual_code = st%code
    if (.not. res%has_dual) return
    o%dual_iters = res%dual_iters
    if (scene%problem == PROBLEM_P1) then
      o%dual_res = res%dual_p1%residual
      o%dual_conv = res%dual_p1%converged .and. .not. res%dual_limit
      if (allocated(res%q)) o%finite = o%finite .and. all_finite(res%q)
      if (allocated(res%q_hdiv)) o%finite = o%finite .and. all_finite(res%q_hdiv)
    else
      o%dual_res = res%dual_p2%defect_solver     ! the solver's defect (the returned field is equilibrated)
      o%dual_conv = res%dual_p2%converged .and. .not. res%dual_limit
      o%finite = o%finite .and. all_finite(reshape(res%lambda%beta, [size(res%lambda%beta)]))
    end if
    o%est = res%est
    o%lo = res%energy_lo
    o%hi = res%energy_hi
    o%finite = o%finite .and. all_finite(res%est_elem)
    o%finite = o%finite .and. ieee_is_finite(o%est) .and. ieee_is_finite(o%lo) .and. ieee_is_finite(o%hi)
  end subroutine level_from_result

  !> The guaranteed-bound expectations of a level: converged primal and dual, finite, est >= 0,
  !> est >= err^2, energy_lo <= (f,u) <= energy_hi (up to the quadrature slacks).
  logical function bounds_hold(o)
    type(level_t), intent(in) :: o
    bounds_hold = o%finite .and. o%conv .and. o%est >= 0.0_dp .and. o%est >= o%err**2 * (1.0_dp - bound_slack)
    if (o%dual_ran) bounds_hold = bounds_hold .and. o%dual_conv .and. &
      o%lo <= o%energy + energy_slack * abs(o%energy) .and. o%hi >= o%energy - energy_slack * abs(o%energy)
  end function bounds_hold

  !> A row from the finest level of a case.
  subroutine add_row(name, varied, o, pass, check, seconds)
    character(len=*), intent(in) :: name, varied, check
    type(level_t), intent(in) :: o
    logical, intent(in) :: pass
    real(dp), intent(in), optional :: seconds
    type(row_t) :: r
    r%name = name
    r%varied = varied
    r%conv = o%conv .and. (o%dual_conv .or. .not. o%dual_ran)
    r%iters = o%iters
    r%kkt = o%kkt
    if (o%dual_ran) r%dual_res = o%dual_res
    r%err = o%err
    if (o%dual_ran) then
      r%sqrt_est = sqrt(max(o%est, 0.0_dp))
      if (o%err > 0.0_dp) r%eff = r%sqrt_est / o%err
    end if
    r%seconds = o%seconds
    if (present(seconds)) r%seconds = seconds
    r%pass = pass
    r%check = check
    call push(r)
  end subroutine add_row

  subroutine push(r)
    type(row_t), intent(in) :: r
    if (nrows == max_rows) return
    nrows = nrows + 1
    rows(nrows) = r
    write (*, '(a,a28,1x,a34,1x,a4,i9,es10.2,es11.3,f9.2,1x,a,2x,a)') '  ', r%name, r%varied, &
      merge('yes ', 'no  ', r%conv), r%iters, r%kkt, r%err, r%seconds, merge('PASS', 'FAIL', r%pass), trim(r%check)
    flush (output_unit)
  end subroutine push

  !> Levels 1..nlev of `coarse` refined uniformly by the pipeline, grid sequencing
  !> (interpolated start); all levels must satisfy the bounds; `o` returns the finest level,
  !> all_ok the verdict.
  subroutine run_levels(coarse, scene, nlev, o, all_ok, seconds, dual)
    type(mesh_t), intent(in) :: coarse
    type(scene_t), intent(in) :: scene
    integer, intent(in) :: nlev
    type(level_t), intent(out) :: o
    logical, intent(out) :: all_ok
    real(dp), intent(out) :: seconds
    logical, intent(in), optional :: dual
    type(analysis_t) :: an
    type(level_result_t) :: res
    type(status_t) :: st
    integer :: level
    logical :: with_dual
    with_dual = .true.
    if (present(dual)) with_dual = dual
    all_ok = .true.
    seconds = 0.0_dp
    call analysis_start(an, stress_analysis_problem(coarse, scene), stress_settings(nlev, with_dual), st)
    do level = 1, nlev
      if (is_ok(st)) call analysis_next_level(an, res, st)
      call level_from_result(an, scene, res, st, o)
      seconds = seconds + o%seconds
      all_ok = all_ok .and. bounds_hold(o)
    end do
  end subroutine run_levels

  ! ================================================================== mesh quality
  subroutine cases_mesh_quality()
    type(scene_t) :: scene
    type(status_t) :: st
    type(mesh_t) :: mesh
    type(mesh_quality_t) :: q
    type(level_t) :: o
    real(dp) :: secs, angle
    integer :: k, nlev, ny, n
    logical :: ok, flagged_all
    character(len=120) :: check
    character(len=10), parameter :: names(2) = ['p2_contact', 'p1_contact']
    nlev = merge(2, 3, quick)
    ! needles: nx = 2 cells, ny = nx / tan(angle): right triangles with the given smallest angle
    do k = 1, 2
      angle = merge(2.0_dp, 0.5_dp, k == 1)
      ny = nint(2.0_dp / tan(angle * acos(-1.0_dp) / 180.0_dp))
      call mesh_rectangle(mesh, 0.0_dp, 1.0_dp, 0.0_dp, 1.0_dp, 2, ny, 'right', st)
      q = mesh_quality(mesh)
      do n = 1, 2
        call scene_lookup(names(n), scene, st)
        call run_levels(mesh, scene, nlev, o, ok, secs)
        write (check, '(a,f6.3,a,a)') 'min angle ', q%min_angle_deg, ' deg, est>=err^2, bounds; flagged: ', &
          trim(flag_text(q))
        call add_row('needle_' // trim(fmt_g(angle)) // 'deg_' // names(n)(1:2), '2x' // itoa(ny) // &
          ' cells, ' // itoa(nlev) // ' levels', o, ok .and. q%flag_small_angle .and. q%flag_shape, check, secs)
      end do
    end do
    ! graded towards the corner (0,0): size ratio > 1e3 between the corner and the far region
    call mesh_corner_graded(mesh, 0.0_dp, 1.0_dp, 0.0_dp, 1.0_dp, 10, st)
    q = mesh_quality(mesh)
    do n = 1, 2
      call scene_lookup(names(n), scene, st)
      call run_levels(mesh, scene, nlev + 1, o, ok, secs)
      write (check, '(a,es8.2,a,a)') 'h/h_min ', q%global_side_ratio, ', est>=err^2, bounds; flagged: ', &
        trim(flag_text(q))
      call add_row('graded_corner_' // names(n)(1:2), '10 layers, ' // itoa(nlev + 1) // ' levels', o, &
        ok .and. q%flag_graded, check, secs)
    end do
    ! long thin domain (0,1) x (0,1e-3): square cells, then needle cells
    do k = 1, 2
      if (k == 1) then
        call mesh_rectangle(mesh, 0.0_dp, 1.0_dp, 0.0_dp, 1.0e-3_dp, 1000, 1, 'right', st)
      else
        call mesh_rectangle(mesh, 0.0_dp, 1.0_dp, 0.0_dp, 1.0e-3_dp, 8, 1, 'right', st)
      end if
      q = mesh_quality(mesh)
      do n = 1, 2
        if (n == 1) call stress_problem('p2_full_contact', 1.0_dp, 1.0e-3_dp, scene, st)
        if (n == 2) call stress_problem('p1_full_contact', 1.0_dp, 1.0e-3_dp, scene, st)
        call run_levels(mesh, scene, nlev, o, ok, secs)
        write (check, '(a,f7.3,a,a)') 'aspect 1:1000, min angle ', q%min_angle_deg, &
          ', est>=err^2, bounds; flagged: ', trim(flag_text(q))
        if (k == 1) then
          call add_row('thin_1000_square_cells_' // names(n)(1:2), '1000x1 cells, ' // itoa(nlev) // ' levels', o, &
            ok, check, secs)
        else
          call add_row('thin_1000_needles_' // names(n)(1:2), '8x1 cells, ' // itoa(nlev) // ' levels', o, &
            ok .and. q%flagged, check, secs)
        end if
      end do
    end do
    ! a family violating the alpha-beta regularity: nx = 2^k, ny = 4^k, smallest angle atan(2^-k) -> 0
    call scene_lookup('p2_contact', scene, st)
    ok = .true.
    flagged_all = .true.
    secs = 0.0_dp
    block
      real(dp), allocatable :: u(:)
      real(dp) :: err_prev
      err_prev = huge(1.0_dp)
      do k = 1, merge(4, 5, quick)
        call mesh_rectangle(mesh, 0.0_dp, 1.0_dp, 0.0_dp, 1.0_dp, 2**k, 4**k, 'right', st)
        q = mesh_quality(mesh)
        if (allocated(u)) deallocate (u)
        call solve_level(mesh, scene, u, o, .true.)
        secs = secs + o%seconds
        ok = ok .and. bounds_hold(o) .and. o%err < err_prev
        err_prev = o%err
      end do
      write (check, '(a,f6.3,a,a)') 'angles -> 0 (', q%min_angle_deg, ' deg), err decreasing, est>=err^2; flagged: ', &
        trim(flag_text(q))
      call add_row('alpha_beta_violated_p2', 'nx=2^k, ny=4^k, k=1..' // itoa(k - 1), o, ok .and. q%flag_small_angle, &
        check, secs)
    end block
  end subroutine cases_mesh_quality

  !> The flags of a quality report, as text.
  function flag_text(q) result(s)
    type(mesh_quality_t), intent(in) :: q
    character(len=:), allocatable :: s
    s = ''
    if (q%flag_small_angle) s = s // 'angle '
    if (q%flag_shape) s = s // 'shape '
    if (q%flag_graded) s = s // 'graded '
    if (len(s) == 0) s = 'none'
    s = trim(s)
  end function flag_text

  ! ================================================================== scaling
  subroutine cases_scaling()
    type(scene_t) :: base
    type(status_t) :: st
    type(level_t) :: ref, o
    real(dp) :: s_values(4) = [1.0e-8_dp, 1.0e-4_dp, 1.0e4_dp, 1.0e8_dp]
    real(dp) :: l_values(4) = [1.0e-4_dp, 1.0e-2_dp, 1.0e2_dp, 1.0e4_dp]
    integer :: n, k, level
    character(len=10), parameter :: names(2) = ['p1_contact', 'p2_contact']
    level = merge(4, 5, quick)
    do n = 1, 2
      call scene_lookup(names(n), base, st)
      call scaled_run(base, 1.0_dp, 1.0_dp, level, ref)
      do k = 1, size(s_values)
        call scaled_run(base, s_values(k), 1.0_dp, level, o)
        call scaled_row('scale_f_' // names(n)(1:2), 'f x ' // trim(fmt_g(s_values(k))), s_values(k), ref, o)
      end do
      if (base%problem == PROBLEM_P1) cycle      ! -Lap u + u = f: no length-scale invariance
      do k = 1, size(l_values)
        call scaled_run(base, 1.0_dp, l_values(k), level, o)
        call scaled_row('scale_domain_' // names(n)(1:2), 'domain x ' // trim(fmt_g(l_values(k))), 1.0_dp, ref, o)
      end do
      call scaled_run(base, 1.0e8_dp, 1.0e-4_dp, level, o)
      call scaled_row('scale_both_' // names(n)(1:2), 'f x 1e8, domain x 1e-4', 1.0e8_dp, ref, o)
    end do
  end subroutine cases_scaling

    !> The scene b rescaled by (s, L) on the level-`level` mesh of (0,L)^2.
    subroutine scaled_run(b, s, l, level, out)
      type(scene_t), intent(in) :: b
      real(dp), intent(in) :: s, l
      integer, intent(in) :: level
      type(level_t), intent(out) :: out
      type(scene_t) :: scene
      type(status_t) :: st
      type(mesh_t) :: mesh, fine
      real(dp), allocatable :: u(:)
      integer :: j
      call stress_scaled_scene(b, s, l, scene, st)
      call mesh_rectangle(mesh, 0.0_dp, l, 0.0_dp, l, 2, 2, 'right', st)
      do j = 2, level
        call mesh_refine_uniform(mesh, fine, st)
        mesh = fine
      end do
      call solve_level(mesh, scene, u, out, .true.)
    end subroutine scaled_run

    !> Relative error err/s and effectivity against the unscaled reference.
    subroutine scaled_row(name, varied, s, r, x)
      character(len=*), intent(in) :: name, varied
      real(dp), intent(in) :: s
      type(level_t), intent(in) :: r, x
      real(dp) :: d_err, d_eff
      character(len=120) :: check
      ! the energy norm scales with s in both problems (P2: |s u(./L)|_1 = s |u|_1 in 2D)
      d_err = abs((x%err / s) / r%err - 1.0_dp)
      d_eff = abs((sqrt(x%est) / x%err) / (sqrt(r%est) / r%err) - 1.0_dp)
      write (check, '(a,es8.1,a,es8.1,a,es7.0)') 'rel.err ratio - 1: ', d_err, ', eff ratio - 1: ', d_eff, ', both <= ', &
        scale_tol
      call add_row(name, varied, x, bounds_hold(x) .and. d_err <= scale_tol .and. d_eff <= scale_tol, check)
    end subroutine scaled_row

  ! ================================================================== contact extremes
  subroutine cases_contact()
    type(scene_t) :: scene
    type(status_t) :: st
    type(mesh_t) :: mesh, finer
    type(level_t) :: o
    real(dp) :: secs
    real(dp), allocatable :: u(:), uf(:)
    integer :: n, level, nlev, changes, nchanged_levels
    logical :: ok, on_node
    logical, allocatable :: bottom(:), predicted(:)
    character(len=120) :: check
    character(len=16), parameter :: full(2) = ['p2_full_contact', 'p1_full_contact']
    character(len=16), parameter :: none(2) = ['p2_no_contact   ', 'p1_offset       ']
    character(len=10), parameter :: names(2) = ['p2_contact', 'p1_contact']
    nlev = merge(4, 6, quick)
    do n = 1, 2
      call stress_problem(full(n), 1.0_dp, 1.0_dp, scene, st)
      call mesh_rectangle(mesh, 0.0_dp, 1.0_dp, 0.0_dp, 1.0_dp, 2, 2, 'right', st)
      call run_levels(mesh, scene, nlev, o, ok, secs)
      write (check, '(a,i0,a,i0,a)') 'contact at ', o%ncontact, ' of ', o%nbounded, &
        ' Signorini nodes (all); est>=err^2, bounds'
      call add_row('all_in_contact_' // full(n)(1:2), trim(full(n)), o, ok .and. o%ncontact == o%nbounded, check, secs)
    end do
    do n = 1, 2
      call stress_problem(trim(none(n)), 1.0_dp, 1.0_dp, scene, st)
      call mesh_rectangle(mesh, 0.0_dp, 1.0_dp, 0.0_dp, 1.0_dp, 2, 2, 'right', st)
      call run_levels(mesh, scene, nlev, o, ok, secs)
      write (check, '(a,i0,a,i0,a)') 'contact at ', o%ncontact, ' of ', o%nbounded, &
        ' Signorini nodes (none); est>=err^2, bounds'
      call add_row('nothing_in_contact_' // none(n)(1:2), trim(none(n)), o, ok .and. o%ncontact == 0, check, secs)
    end do
    ! the contact set changes at every level: the transition x = 1/3 is never a node, the
    ! interpolated coarse solution mispredicts the set near it; grid sequencing
    do n = 1, 2
      call scene_lookup(names(n), scene, st)
      call mesh_rectangle(mesh, 0.0_dp, 1.0_dp, 0.0_dp, 1.0_dp, 2, 2, 'right', st)
      ok = .true.
      secs = 0.0_dp
      nchanged_levels = 0
      if (allocated(u)) deallocate (u)
      do level = 1, nlev + 1
        if (level > 1) then
          call mesh_refine_uniform(mesh, finer, st)
          allocate (uf(finer%nnode))
          call mesh_prolongate_p1(mesh, finer, u, uf)
          call move_alloc(uf, u)
          mesh = finer
        end if
        bottom = mesh%node_on_boundary .and. mesh%xy(2, :) == 0.0_dp
        if (allocated(u)) then
          predicted = u <= 0.0_dp                    ! contact set of the start (interpolated)
        else
          allocate (predicted(mesh%nnode), source=.true.)
        end if
        call solve_level(mesh, scene, u, o, .true.)
        secs = secs + o%seconds
        ok = ok .and. bounds_hold(o)
        changes = count(bottom .and. (predicted .neqv. (u <= 0.0_dp)))
        if (level > 1 .and. changes > 0) nchanged_levels = nchanged_levels + 1
        deallocate (bottom, predicted)
      end do
      write (check, '(a,i0,a,i0,a)') 'interpolated contact set wrong on ', nchanged_levels, ' of ', nlev, &
        ' refined levels; est>=err^2, bounds on all'
      call add_row('moving_contact_' // names(n)(1:2), 'grid sequencing, ' // itoa(nlev + 1) // ' levels', o, &
        ok .and. nchanged_levels > 0, check, secs)
    end do
    ! the transition x = 1/3 exactly on a node: coarse mesh of 3 x 3 cells (u = du/dnu = 0 there)
    do n = 1, 2
      call scene_lookup(names(n), scene, st)
      call mesh_rectangle(mesh, 0.0_dp, 1.0_dp, 0.0_dp, 1.0_dp, 3, 3, 'right', st)
      on_node = any(mesh%xy(1, :) == scene%x_breaks(1) .and. mesh%xy(2, :) == 0.0_dp)
      call run_levels(mesh, scene, nlev, o, ok, secs)
      write (check, '(a,l1,a)') 'node at x=1/3 on y=0: ', on_node, '; est>=err^2, bounds on all levels'
      call add_row('transition_on_node_' // names(n)(1:2), '3x3 coarse cells, ' // itoa(nlev) // ' levels', o, &
        ok .and. on_node, check, secs)
    end do
  end subroutine cases_contact

  ! ================================================================== parameters
  subroutine cases_parameters()
    type(scene_t) :: scene
    type(status_t) :: st
    type(mesh_t) :: mesh, fine
    type(level_t) :: o, ref
    real(dp), allocatable :: u(:), u_ref(:)
    real(dp) :: dev, omegas(2) = [0.02_dp, 1.999_dp]
    integer :: k, level
    character(len=120) :: check
    level = merge(3, 4, quick)
    call scene_lookup('p2_contact', scene, st)
    call mesh_rectangle(mesh, 0.0_dp, 1.0_dp, 0.0_dp, 1.0_dp, 2, 2, 'right', st)
    do k = 2, level
      call mesh_refine_uniform(mesh, fine, st)
      mesh = fine
    end do
    call solve_level(mesh, scene, u_ref, ref, .false.)
    ! omega -> 0 and omega -> 2: slow but convergent; the same solution as the active set
    do k = 1, 2
      if (allocated(u)) deallocate (u)
      call solve_level(mesh, scene, u, o, .true., 'psor', omegas(k), 5000000)
      dev = norm2(u - u_ref) / norm2(u_ref)
      write (check, '(a,es8.1,a)') 'KKT<=1e-10, relative distance to the active-set solution ', dev, '; est>=err^2'
      call add_row('omega_' // trim(fmt_g(omegas(k))), 'PSOR, level ' // itoa(level), o, &
        bounds_hold(o) .and. o%code == DS_OK .and. dev <= omega_ref_tol, check)
    end do
    ! omega = 0 and omega = 2 are outside (0,2): rejected with a message
    block
      type(primal_system_t) :: sys
      type(psor_settings_t) :: pset
      type(psor_result_t) :: pres
      type(status_t) :: st0, st2
      type(level_t) :: none
      call primal_assemble(mesh, scene%problem, scene%f, tri_rule(load_degree), sys, st=st)
      call primal_constraints(mesh, scene%problem, [2, 3, 4], [1], sys%kind, sys%bnd, st)
      u = 0.0_dp
      pset%omega = 0.0_dp
      call psor_solve(sys%a, sys%load, sys%kind, sys%bnd, u, pset, pres, st0)
      pset%omega = 2.0_dp
      call psor_solve(sys%a, sys%load, sys%kind, sys%bnd, u, pset, pres, st2)
      check = 'DS_ERR_INPUT: ' // trim(msg_of(st2))
      none%conv = .false.
      none%kkt = -1.0_dp
      none%err = -1.0_dp
      call add_row('omega_0_and_2_rejected', 'PSOR omega = 0, 2', none, &
        st0%code == DS_ERR_INPUT .and. st2%code == DS_ERR_INPUT .and. len_trim(msg_of(st2)) > 0, check)
      ! iteration limit of projected SOR: reported, never a silent "converged"
      u = 0.0_dp
      pset%omega = 1.0_dp
      pset%max_iter = 10
      call psor_solve(sys%a, sys%load, sys%kind, sys%bnd, u, pset, pres, st)
      none%iters = pres%iterations
      none%kkt = pres%kkt_residual
      none%conv = pres%converged
      call add_row('iter_limit_psor', 'PSOR max_iter = 10', none, .not. pres%converged .and. &
        st%code == DS_WARN_NOT_CONVERGED .and. all_finite(u), 'DS_WARN_NOT_CONVERGED: ' // trim(msg_of(st)))
      ! iteration limit of the active set: the projected-SOR fallback; a warning only when
      ! the fallback did not converge either
      block
        type(active_set_settings_t) :: aset
        type(active_set_result_t) :: ares
        u = 0.0_dp
        aset%max_iter = 1
        call active_set_solve(sys%a, sys%load, sys%kind, sys%bnd, u, aset, ares, st)
        none%iters = ares%iterations
        none%kkt = ares%kkt_residual
        none%conv = ares%converged .and. st%code == DS_OK
        call add_row('iter_limit_active_set', 'active set max_iter = 1', none, ares%fallback .and. &
          (ares%converged .eqv. st%code == DS_OK) .and. all_finite(u), 'fallback: ' // trim(msg_of(st)))
      end block
    end block
    call rho_cases(mesh)
  end subroutine cases_parameters

  !> Uzawa (dual of P1) with rho far too large, with an automatic rho that is too large, and
  !> at its iteration limit.
  subroutine rho_cases(mesh_in)
    type(mesh_t), intent(in) :: mesh_in
    type(scene_t) :: scene
    type(status_t) :: st
    type(csr_t) :: a
    type(rect_t) :: bmat
    type(cholmod_spd_t) :: chol
    type(uzawa_settings_t) :: uset
    type(uzawa_result_t) :: ures, auto
    type(level_t) :: o
    real(dp), allocatable :: b(:), y(:), z(:), zero(:)
    integer, allocatable :: row_node(:), row_kind(:)
    real(dp) :: t0
    call scene_lookup('p1_contact', scene, st)
    allocate (b(2 * mesh_in%nnode), y(2 * mesh_in%nnode))
    call assemble_dual_p1(mesh_in, scene%f, tri_rule(load_degree), a, b, st=st)
    call chol%factor(a, st)
    call dual_p1_constraint_rows(mesh_in, bmat, row_node, st=st)
    allocate (z(bmat%m), zero(bmat%m), source=0.0_dp)
    allocate (row_kind(bmat%m), source=ROW_INEQUALITY)
    ! the automatic rho, for reference (converges)
    uset%tol = 1.0e-8_dp
    uset%max_iter = 100000
    call uzawa_solve(chol, b, bmat, row_kind, zero, y, z, uset, auto, st)
    ! a user rho 100 times the automatic one: the divergence must be an error, quickly
    z = 0.0_dp
    uset%rho = 100.0_dp * auto%rho
    t0 = wall_seconds()
    call uzawa_solve(chol, b, bmat, row_kind, zero, y, z, uset, ures, st)
    o%seconds = wall_seconds() - t0
    o%iters = ures%iterations
    o%kkt = -1.0_dp
    o%err = -1.0_dp
    call add_row('rho_far_too_large_user', 'Uzawa rho = 100 x auto (P1 dual)', o, st%code == DS_ERR_NUMERIC .and. &
      ures%iterations <= quick_divergence_iters .and. len_trim(msg_of(st)) > 0, &
      'error after ' // itoa(ures%iterations) // ' it.: ' // trim(msg_of(st)))
    ! iteration limit: reported as not converged
    z = 0.0_dp
    uset%rho = 0.0_dp
    uset%max_iter = 5
    t0 = wall_seconds()
    call uzawa_solve(chol, b, bmat, row_kind, zero, y, z, uset, ures, st)
    o%seconds = wall_seconds() - t0
    o%iters = ures%iterations
    o%conv = ures%converged
    o%dual_res = ures%residual
    call add_row('iter_limit_uzawa', 'Uzawa max_iter = 5 (P1 dual)', o, .not. ures%converged .and. &
      st%code == DS_WARN_NOT_CONVERGED .and. all_finite(y), 'DS_WARN_NOT_CONVERGED: ' // trim(msg_of(st)))
    call chol%free()
    call auto_rho_retry()
  end subroutine rho_cases

  !> An automatic rho that is too large: min 1/2|y|^2 - b.y subject to B y >= 0 with
  !> B B^T = Q diag(lam_small, lam_big) Q^T and the power iteration's (deterministic) start
  !> vector an eigenvector of lam_small, so that lambda_max is underestimated by
  !> lam_big / lam_small and rho = 1.5 / lam_small diverges.  Expected: the divergence is
  !> detected, rho is halved until it converges (retries > 0), the result is correct.
  subroutine auto_rho_retry()
    real(dp), parameter :: lam_small = 1.0_dp, lam_big = 10.0_dp
    type(block_diag_spd_t) :: ident
    type(rect_t) :: bmat
    type(uzawa_settings_t) :: uset
    type(uzawa_result_t) :: ures
    type(status_t) :: st
    type(level_t) :: o
    real(dp) :: v(2), w(2), qm(2, 2), bm(2, 2), blocks(2, 2, 1), y(2), z(2), b(2), t0
    integer :: k
    do k = 1, 2
      v(k) = 1.0_dp + 0.5_dp * sin(1.618033988749895_dp * k)   ! uzawa_lambda_max's start vector
    end do
    v = v / norm2(v)
    w = [-v(2), v(1)]
    qm(:, 1) = v
    qm(:, 2) = w
    bm = matmul(qm, matmul(reshape([sqrt(lam_small), 0.0_dp, 0.0_dp, sqrt(lam_big)], [2, 2]), transpose(qm)))
    call rect_from_triplets(2, 2, [1, 1, 2, 2], [1, 2, 1, 2], [bm(1, 1), bm(1, 2), bm(2, 1), bm(2, 2)], bmat, st=st)
    blocks(:, :, 1) = reshape([1.0_dp, 0.0_dp, 0.0_dp, 1.0_dp], [2, 2])
    call ident%factor(blocks, st)
    ! b pushes y out of {B y >= 0} in both directions: both constraints active at the solution
    b = -matmul(transpose(bm), [1.0_dp, 1.0_dp])
    z = 0.0_dp
    uset%tol = 1.0e-12_dp
    uset%max_iter = 100000
    t0 = wall_seconds()
    call uzawa_solve(ident, b, bmat, [ROW_INEQUALITY, ROW_INEQUALITY], [0.0_dp, 0.0_dp], y, z, uset, ures, st)
    o%seconds = wall_seconds() - t0
    o%iters = ures%iterations
    o%conv = ures%converged
    o%dual_res = ures%residual
    o%dual_ran = .false.
    o%kkt = -1.0_dp
    o%err = -1.0_dp
    ! the solution of this QP is y = 0 (B y >= 0 with both rows active, B invertible)
    call add_row('rho_auto_too_large_retry', 'auto rho 10x too large (2x2 QP)', o, st%code == DS_OK .and. &
      ures%converged .and. ures%retries > 0 .and. norm2(y) <= 1.0e-9_dp * norm2(b), &
      'divergence detected, ' // itoa(ures%retries) // ' retries with rho halved, then converged to y = 0')
  end subroutine auto_rho_retry

  ! ================================================================== floating point
  subroutine cases_floating_point()
    type(scene_t) :: scene
    type(status_t) :: st
    type(mesh_t) :: mesh
    type(level_t) :: o
    real(dp) :: secs, gap
    logical :: ok
    character(len=120) :: check
    integer :: n
    character(len=12), parameter :: zero(2) = ['p2_zero_load', 'p1_zero_load']
    ! catastrophic cancellation: energies ~ 1e12, error^2 ~ 1e-3
    call stress_problem('p1_offset', 1.0_dp, 1.0_dp, scene, st)
    call mesh_rectangle(mesh, 0.0_dp, 1.0_dp, 0.0_dp, 1.0_dp, 2, 2, 'right', st)
    call run_levels(mesh, scene, merge(4, 5, quick), o, ok, secs)
    gap = o%hi - o%lo
    write (check, '(a,es9.2,a,es9.2,a,es8.1,a,es8.1)') 'est ', o%est, ' >= 0 from its terms; hi-lo ', gap, &
      ' off by ', abs(gap - o%est) / o%est, ' (cancellation), energy ', o%hi
    call add_row('cancellation_p1_offset', 'u = 1e6 + cos cos', o, ok .and. o%est >= 0.0_dp .and. &
      o%lo <= o%hi + order_ulps * epsilon(1.0_dp) * abs(o%hi), check, secs)
    ! zero load: u = 0, relative residuals 0/0
    do n = 1, 2
      call stress_problem(zero(n), 1.0_dp, 1.0_dp, scene, st)
      call run_levels(mesh, scene, 3, o, ok, secs)
      write (check, '(a,es9.2,a,es9.2,a,es9.2)') 'finite; est ', o%est, ', lo ', o%lo, ', hi ', o%hi
      call add_row('zero_load_' // zero(n)(1:2), 'f = 0', o, o%finite .and. o%conv .and. o%dual_conv .and. &
        o%est == 0.0_dp .and. o%err == 0.0_dp, check, secs)
    end do
  end subroutine cases_floating_point

  ! ================================================================== size
  !> The largest meshes, each in its own process (see size_child): P2 primal (active set, grid
  !> sequencing) at max_level, P1 primal + feasible dual + bounds at max_level - 1.
  subroutine cases_size()
    character(len=16), parameter :: kinds(2) = [character(len=16) :: 'p2_primal', 'p1_primal_dual']
    integer :: k, rc, u, ios, lvl
    character(len=512) :: cmd, tmp
    type(level_t) :: o
    real(dp) :: peak_mb, bytes_per
    integer :: unknowns
    logical :: ok
    character(len=120) :: check
    type(status_t) :: st
    do k = 1, 2
      lvl = max_level - (k - 1)
      if (quick) lvl = min(lvl, 6)
      tmp = trim(out_dir) // '/stress_size_' // trim(kinds(k)) // '.tmp'
      write (cmd, '(a,a,i0,a,a,a,a)') trim(self_path), ' --max-level ', lvl, ' --size-child ', &
        trim(kinds(k)), ' > ', trim(tmp)
      call ensure_parent_dir(tmp, st)
      call execute_command_line(trim(cmd), exitstat=rc)
      ok = .false.
      open (newunit=u, file=tmp, status='old', action='read', iostat=ios)
      if (ios == 0) then
        read (u, *, iostat=ios) o%conv, o%dual_conv, o%dual_ran, o%finite, o%iters, o%kkt, o%dual_res, o%err, &
          o%est, o%seconds, peak_mb, unknowns
        close (u, status='delete')
        ok = ios == 0
      end if
      if (.not. ok) then
        o = level_t()
        check = 'the size child failed (exit status ' // itoa(rc) // ')'
      else
        bytes_per = peak_mb * 1024.0_dp**2 / max(unknowns, 1)
        write (check, '(a,i0,a,f8.0,a,f6.0,a)') 'unknowns ', unknowns, ', peak ', peak_mb, ' MB = ', bytes_per, &
          ' bytes/unknown'
        ok = o%finite .and. o%conv .and. (o%dual_conv .or. .not. o%dual_ran)
        if (o%dual_ran) ok = ok .and. o%est >= o%err**2 * (1.0_dp - bound_slack)
      end if
      call add_row('size_' // trim(kinds(k)), 'level ' // itoa(lvl) // ', own process', o, ok, check)
    end do
  end subroutine cases_size

  !> Internal entry: one size case in this process; prints one line of numbers and stops.
  subroutine size_child(kind_name)
    character(len=*), intent(in) :: kind_name
    type(scene_t) :: scene
    type(status_t) :: st
    type(mesh_t) :: mesh, finer
    type(level_t) :: o
    real(dp), allocatable :: u(:), uf(:)
    integer :: level
    real(dp) :: secs
    if (kind_name == 'p2_primal') then
      call scene_lookup('p2_contact', scene, st)
    else
      call scene_lookup('p1_contact', scene, st)
    end if
    call mesh_rectangle(mesh, 0.0_dp, 1.0_dp, 0.0_dp, 1.0_dp, 2, 2, 'right', st)
    secs = 0.0_dp
    do level = 1, max_level
      if (level > 1) then
        call mesh_refine_uniform(mesh, finer, st)
        allocate (uf(finer%nnode))
        call mesh_prolongate_p1(mesh, finer, u, uf)
        call move_alloc(uf, u)
        mesh = finer
      end if
      call solve_level(mesh, scene, u, o, kind_name /= 'p2_primal' .and. level == max_level)
      secs = secs + o%seconds
    end do
    write (*, *) o%conv, o%dual_conv, o%dual_ran, o%finite, o%iters, o%kkt, o%dual_res, o%err, o%est, secs, &
      peak_memory_mb(), merge(mesh%nnode, 3 * mesh%nnode, kind_name == 'p2_primal')
    stop
  end subroutine size_child

  ! ================================================================== output
  !> out/stress.txt (aligned) and out/stress.md (Markdown), written atomically; exit 1 on FAIL.
  subroutine write_tables()
    type(status_t) :: st
    character(len=:), allocatable :: txt, md
    integer :: u, k, nfail
    character(len=400) :: line
    character(len=80) :: cmdline
    txt = trim(out_dir) // '/stress.txt'
    md = trim(out_dir) // '/stress.md'
    call ensure_parent_dir(txt, st)
    if (st%code /= 0) call fail_output(st)
    nfail = count(.not. rows(1:nrows)%pass)
    write (cmdline, '(a,i0,a)') 'bin/dualsig_stress --max-level ', max_level, merge(' --quick', '        ', quick)
    open (newunit=u, file=temp_name(txt), status='replace', action='write')
    write (u, '(a)') '# dualsig stress suite: ' // trim(cmdline)
    write (u, '(a,i0,a,i0,a,f7.1,a)') '# ', nrows, ' cases, ', nfail, ' FAIL, ', wall_seconds() - t_start, ' s'
    write (u, '(a)') '# kkt: relative KKT residual of the primal solve; dual_res: P1 dual KKT residual, P2 divergence' // &
      ' defect of the solver (before equilibration), Uzawa residual; eff = sqrt(est)/err_u_H1; -1: not applicable'
    write (u, '(a28,1x,a34,1x,a4,a9,a10,a10,a11,a11,a11,a9,1x,a7,2x,a)') 'case', 'varied', 'conv', 'iters', 'kkt', &
      'dual_res', 'err_u_H1', 'sqrt(est)', 'eff', 's', 'verdict', 'check'
    do k = 1, nrows
      associate (r => rows(k))
        write (u, '(a28,1x,a34,1x,a4,i9,es10.2,es10.2,es11.3,es11.3,es11.4,f9.3,1x,a7,2x,a)') r%name, r%varied, &
          merge('yes ', 'no  ', r%conv), r%iters, r%kkt, r%dual_res, r%err, r%sqrt_est, r%eff, r%seconds, &
          merge('PASS', 'FAIL', r%pass), trim(r%check)
      end associate
    end do
    close (u)
    call file_commit(txt, st)
    if (st%code /= 0) call fail_output(st)
    open (newunit=u, file=temp_name(md), status='replace', action='write')
    write (u, '(a)') '| case | varied | converged | iterations | KKT | dual residual | err_u_H1 | √est | eff | s |' // &
      ' verdict | check |'
    write (u, '(a)') '| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |'
    do k = 1, nrows
      associate (r => rows(k))
        write (line, '(a,i0,a)') '| ' // trim(r%name) // ' | ' // trim(r%varied) // ' | ' // &
          trim(merge('yes', 'no ', r%conv)) // ' | ', r%iters, ' | ' // na(r%kkt, '(es8.1)') // ' | ' // &
          na(r%dual_res, '(es8.1)') // ' | ' // na(r%err, '(es10.3)') // ' | ' // na(r%sqrt_est, '(es10.3)') // &
          ' | ' // na(r%eff, '(g12.6)') // ' | ' // na(r%seconds, '(f8.3)') // ' | ' // &
          trim(merge('PASS', 'FAIL', r%pass)) // ' | ' // trim(r%check) // ' |'
        write (u, '(a)') trim(line)
      end associate
    end do
    close (u)
    call file_commit(md, st)
    if (st%code /= 0) call fail_output(st)
    write (*, '(a,i0,a,i0,a,f7.1,a)') 'dualsig_stress: ', nrows, ' cases, ', nfail, ' FAIL, ', wall_seconds() - t_start, &
      ' s; tables written to ' // txt // ' and ' // md
    if (nfail > 0) stop 1
  end subroutine write_tables

  !> A number for the Markdown table, '–' when not applicable (negative).
  function na(x, fmt) result(s)
    real(dp), intent(in) :: x
    character(len=*), intent(in) :: fmt
    character(len=:), allocatable :: s
    character(len=40) :: buf
    if (x < 0.0_dp) then
      s = '–'
    else
      write (buf, fmt) x
      s = trim(adjustl(buf))
    end if
  end function na

  subroutine fail_output(st)
    type(status_t), intent(in) :: st
    write (error_unit, '(a)') 'dualsig_stress: ' // trim(msg_of(st))
    stop 2
  end subroutine fail_output

  ! ================================================================== helpers
  !> The message of a status ('' when none).
  function msg_of(st) result(s)
    type(status_t), intent(in) :: st
    character(len=:), allocatable :: s
    if (allocated(st%msg)) then
      s = st%msg
    else
      s = ''
    end if
  end function msg_of

  !> Short text of a number (1e-08 style for powers of ten).
  function fmt_g(x) result(s)
    real(dp), intent(in) :: x
    character(len=:), allocatable :: s
    character(len=24) :: buf
    if (x >= 0.01_dp .and. x < 100.0_dp) then
      write (buf, '(f8.3)') x
      s = trim(adjustl(buf))
      do while (s(len(s):len(s)) == '0')
        s = s(1:len(s) - 1)
      end do
      if (s(len(s):len(s)) == '.') s = s(1:len(s) - 1)
    else
      write (buf, '(es8.0e1)') x
      s = trim(adjustl(buf))
      s = s(1:1) // s(3:)            ! 1.E-8 -> 1E-8
    end if
  end function fmt_g

  logical function all_finite(v)
    real(dp), intent(in) :: v(:)
    all_finite = all(ieee_is_finite(v))
  end function all_finite

end program dualsig_stress
