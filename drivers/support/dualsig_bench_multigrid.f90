!> The multigrid section of dualsig_bench (`bin/dualsig_bench multigrid [lmax [lmax_base [scene]]]`):
!> the truncated nonsmooth Newton multigrid solver of the primal QP on the refinement
!> hierarchy of the unit square (2 x 2 cells refined uniformly; level l has (2^l + 1)^2 nodes).
!>
!> Three passes, each through the analysis pipeline (method 'multigrid', no dual analysis):
!>  1. grid sequencing to lmax at KKT tolerance 1e-10: per level the unknowns, the solve's
!>     seconds, V-cycles, Galerkin updates, KKT residual, energy error, the peak resident
!>     memory of the process (VmHWM) and per unknown, and the solver's own bytes per unknown.
!>     It runs first so that the peak memory is that of the pipeline and the solver only;
!>  2. to lmax_base: per level the cold multigrid solve (zero start, same hierarchy) and ONE
!>     CHOLMOD analyse + factorise + solve of the same matrix without the constraints (AMD
!>     and geometric nested dissection), and the ratios;
!>  3. nested iteration with one and two V-cycles per level (full multigrid): the total time
!>     of the sequence and the energy error against the converged one of pass 1 (the time to
!>     reach the discretisation error).
!> Tables to standard output and out/bench_multigrid.csv.
module dualsig_bench_multigrid
  use dualsig_kinds, only: dp
  use dualsig_clock, only: wall_seconds, peak_memory_mb
  use dualsig_status, only: status_t, is_ok
  use dualsig_mesh, only: mesh_t
  use dualsig_mesh_generate, only: mesh_rectangle
  use dualsig_quadrature, only: tri_rule
  use dualsig_sparse, only: csr_t
  use dualsig_sparse_direct, only: cholesky_t, cholesky_factor, cholesky_free, cholesky_solve, ORDERING_AMD
  use dualsig_ordering_geometric, only: geometric_ordering
  use dualsig_qp_types, only: BOUND_FIXED
  use dualsig_problem_primal, only: primal_system_t, primal_assemble, primal_constraints
  use dualsig_scenes, only: scene_t, scene_lookup
  use dualsig_solver_multigrid, only: mg_settings_t, mg_result_t, multigrid_solve, mg_memory_bytes
  use dualsig_scene_problem, only: analysis_problem_set_scene
  use dualsig_analysis, only: analysis_problem_t, analysis_settings_t, analysis_t, level_result_t, &
                              analysis_start, analysis_next_level, analysis_free
  implicit none
  private

  public :: bench_multigrid, dirichlet_decoupled

  real(dp), parameter :: tol = 1.0e-10_dp          !! KKT tolerance of every converged solve
  integer, parameter :: first_level = 3            !! levels below are not printed
  integer, parameter :: first_level_base = 5       !! baselines and cold solves from this level
  integer, parameter :: max_levels = 14

contains

  !> The three passes of the module header for `scene_name` (p1_contact or p2_contact).
  subroutine bench_multigrid(lmax, lmax_base, scene_name)
    integer, intent(in) :: lmax, lmax_base
    character(len=*), intent(in) :: scene_name
    type(scene_t) :: scene
    type(analysis_problem_t) :: pb
    type(status_t) :: st
    real(dp) :: err_conv(max_levels), t_nested(max_levels)
    integer :: csv
    call scene_lookup(scene_name, scene, st)
    if (.not. is_ok(st)) then
      write (*, '(a)') 'dualsig_bench multigrid: ' // trim(st%msg)
      return
    end if
    call mesh_rectangle(pb%mesh, 0.0_dp, 1.0_dp, 0.0_dp, 1.0_dp, 2, 2, 'right', st)
    call analysis_problem_set_scene(pb, scene)
    open (newunit=csv, file='out/bench_multigrid.csv', status='replace')
    write (csv, '(a)') 'scene,pass,level,n,seconds,iterations,galerkin_updates,kkt_residual,err_energy,peak_mb,' // &
      'peak_bytes_per_unknown,solver_bytes_per_unknown,base_amd_s,base_nd_s,ratio'
    err_conv = 0.0_dp
    t_nested = 0.0_dp
    call pass_sequencing(pb, scene_name, min(lmax, max_levels), csv, err_conv, t_nested)
    call pass_baselines(pb, scene, scene_name, min(lmax_base, lmax, max_levels), csv, t_nested)
    call pass_fmg(pb, scene_name, min(lmax, max_levels), csv, err_conv)
    close (csv)
    write (*, '(a)') 'dualsig_bench: table written to out/bench_multigrid.csv'
  end subroutine bench_multigrid

  !> Pass 1: grid sequencing to tolerance; err_conv and t_nested per level for the others.
  subroutine pass_sequencing(pb, scene_name, lmax, csv, err_conv, t_nested)
    type(analysis_problem_t), intent(in) :: pb
    character(len=*), intent(in) :: scene_name
    integer, intent(in) :: lmax, csv
    real(dp), intent(inout) :: err_conv(:), t_nested(:)
    type(analysis_settings_t) :: set
    type(analysis_t) :: an
    type(level_result_t) :: res
    type(status_t) :: st
    integer :: level
    real(dp) :: peak, solver_b
    set%levels = lmax
    set%keep_hierarchy = .true.      ! an%mg is read after each level, the last one too
    set%method = 'multigrid'
    set%tol = tol
    set%dual = .false.
    write (*, '(/,a)') 'dualsig_bench: multigrid (TNNMG), ' // scene_name // ', grid sequencing, KKT tolerance 1e-10'
    write (*, '(a)') '  lvl          N   seconds  V-cycles  Galerkin  kkt_residual   err_energy    peak MB  ' // &
      'peak B/unknown  solver B/unknown'
    call analysis_start(an, pb, set, st)
    do level = 1, lmax
      if (is_ok(st)) call analysis_next_level(an, res, st)
      if (.not. is_ok(st)) then
        write (*, '(a,i0,a)') 'dualsig_bench multigrid: level ', level, ': ' // trim(st%msg)
        exit
      end if
      peak = peak_memory_mb()
      solver_b = real(mg_memory_bytes(an%mg, res%nnode), dp) / res%ndof
      err_conv(level) = res%err_energy
      t_nested(level) = res%primal_seconds
      if (level < first_level) cycle
      write (*, '(i5,i11,f10.3,2i10,2es13.3,f11.0,f16.0,f18.0)') level, res%ndof, res%primal_seconds, res%primal_iters, &
        res%primal_factorisations, res%kkt_residual, res%err_energy, peak, peak * 1048576.0_dp / res%ndof, solver_b
      write (csv, '(a,",nested,",i0,",",i0,",",es12.4,2(",",i0),2(",",es12.4),",",f10.1,2(",",f10.1),",0,0,0")') &
        scene_name, level, res%ndof, res%primal_seconds, res%primal_iters, res%primal_factorisations, &
        res%kkt_residual, res%err_energy, peak, peak * 1048576.0_dp / res%ndof, solver_b
      flush (6)
    end do
    call analysis_free(an)
  end subroutine pass_sequencing

  !> Pass 2: cold multigrid solves and one CHOLMOD factorisation per level.
  subroutine pass_baselines(pb, scene, scene_name, lmax, csv, t_nested)
    type(analysis_problem_t), intent(in) :: pb
    type(scene_t), intent(in) :: scene
    character(len=*), intent(in) :: scene_name
    integer, intent(in) :: lmax, csv
    real(dp), intent(in) :: t_nested(:)
    type(analysis_settings_t) :: set
    type(analysis_t) :: an
    type(level_result_t) :: res
    type(status_t) :: st
    type(primal_system_t) :: sys
    type(mg_settings_t) :: mset
    type(mg_result_t) :: mres
    real(dp), allocatable :: x(:)
    real(dp) :: t0, t_cold, tb_amd, tb_nd, best
    integer :: level
    if (lmax < first_level_base) return
    set%levels = lmax
    set%keep_hierarchy = .true.      ! an%mg is read after each level, the last one too
    set%method = 'multigrid'
    set%tol = tol
    set%dual = .false.
    mset%tol = tol
    write (*, '(/,a)') 'dualsig_bench: multigrid against ONE CHOLMOD ordering + analyse + factorise + solve of ' // &
      'the same matrix without the constraints (amd; nd = geometric nested dissection), ' // scene_name
    write (*, '(a)') '  lvl          N    nested      cold  V-cycles   base_amd    base_nd   best/nested  best/cold'
    call analysis_start(an, pb, set, st)
    do level = 1, lmax
      if (is_ok(st)) call analysis_next_level(an, res, st)
      if (.not. is_ok(st)) then
        write (*, '(a,i0,a)') 'dualsig_bench multigrid: level ', level, ': ' // trim(st%msg)
        exit
      end if
      if (level < first_level_base) cycle
      call primal_assemble(an%mesh, scene%problem, scene%f, tri_rule(5), sys, st=st)
      call primal_constraints(an%mesh, scene%problem, scene%gamma_u_markers, scene%gamma_a_markers, &
                              sys%kind, sys%bnd, st)
      allocate (x(an%mesh%nnode), source=0.0_dp)
      t0 = wall_seconds()
      call multigrid_solve(an%mg, sys%a, sys%load, sys%kind, sys%bnd, x, mset, mres, st)
      t_cold = wall_seconds() - t0
      call one_factorisation(an%mesh, sys, tb_amd, tb_nd)
      deallocate (x)
      best = min(tb_amd, tb_nd)
      write (*, '(i5,i11,2f10.3,i10,2f11.3,2f13.2)') level, res%ndof, t_nested(level), t_cold, mres%iterations, &
        tb_amd, tb_nd, best / t_nested(level), best / t_cold
      write (csv, '(a,",nested,",i0,",",i0,",",es12.4,",",i0,",0,0,0,0,0,0",3(",",es12.4))') scene_name, level, &
        res%ndof, t_nested(level), res%primal_iters, tb_amd, tb_nd, best / t_nested(level)
      write (csv, '(a,",cold,",i0,",",i0,",",es12.4,",",i0,",",i0,",",es12.4,",0,0,0,0",3(",",es12.4))') scene_name, &
        level, res%ndof, t_cold, mres%iterations, mres%galerkin_updates, mres%kkt_residual, tb_amd, tb_nd, best / t_cold
      flush (6)
      st = status_t()
    end do
    call analysis_free(an)
  end subroutine pass_baselines

  !> Seconds of one ordering + analyse + factorise + solve of sys%a with only the Dirichlet
  !> rows (the constraints dropped), AMD and geometric nested dissection.
  subroutine one_factorisation(mesh, sys, tb_amd, tb_nd)
    type(mesh_t), intent(in) :: mesh
    type(primal_system_t), intent(in) :: sys
    real(dp), intent(out) :: tb_amd, tb_nd
    type(csr_t) :: ar
    type(cholesky_t) :: chol
    type(status_t) :: st
    real(dp), allocatable :: xb(:)
    integer, allocatable :: perm(:)
    integer :: ord
    real(dp) :: t0
    ar = dirichlet_decoupled(sys)
    allocate (xb(ar%n))
    t0 = wall_seconds()
    call cholesky_factor(ar, chol, st, ORDERING_AMD)
    call cholesky_solve(chol, sys%load, xb, st)
    tb_amd = wall_seconds() - t0
    call cholesky_free(chol)
    t0 = wall_seconds()
    call geometric_ordering(mesh%xy, ar, ord, perm, st)
    call cholesky_factor(ar, chol, st, ord, perm)
    call cholesky_solve(chol, sys%load, xb, st)
    tb_nd = wall_seconds() - t0
    call cholesky_free(chol)
  end subroutine one_factorisation

  !> Pass 3: nested iteration with k = 1, 2 V-cycles per level: the time of the whole
  !> sequence and the energy error against the converged one.
  subroutine pass_fmg(pb, scene_name, lmax, csv, err_conv)
    type(analysis_problem_t), intent(in) :: pb
    character(len=*), intent(in) :: scene_name
    integer, intent(in) :: lmax, csv
    real(dp), intent(in) :: err_conv(:)
    type(analysis_settings_t) :: set
    type(analysis_t) :: an
    type(level_result_t) :: res
    type(status_t) :: st
    integer :: level, k
    real(dp) :: total
    write (*, '(/,a)') 'dualsig_bench: nested iteration with k V-cycles per level (full multigrid), ' // scene_name // &
      ': seconds of the whole sequence so far, err_energy / err_energy of the converged solve'
    write (*, '(a)') '  lvl          N   k   seconds(sum)  kkt_residual   err_energy   err/err_converged'
    do k = 1, 2
      set%levels = lmax
      set%method = 'multigrid'
      set%tol = tol
      set%max_iter = k
      set%dual = .false.
      call analysis_start(an, pb, set, st)
      total = 0.0_dp
      do level = 1, lmax
        if (is_ok(st)) call analysis_next_level(an, res, st)
        if (.not. is_ok(st)) then
          write (*, '(a,i0,a)') 'dualsig_bench multigrid: level ', level, ': ' // trim(st%msg)
          exit
        end if
        total = total + res%primal_seconds
        if (level < first_level) cycle
        write (*, '(i5,i11,i4,f15.3,2es13.3,f20.4)') level, res%ndof, k, total, res%kkt_residual, res%err_energy, &
          res%err_energy / err_conv(level)
        write (csv, '(a,",fmg",i0,",",i0,",",i0,",",es12.4,",",i0,",0",2(",",es12.4),",0,0,0,0,0",",",es12.4)') &
          scene_name, k, level, res%ndof, total, res%primal_iters, res%kkt_residual, res%err_energy, &
          res%err_energy / err_conv(level)
        flush (6)
      end do
      call analysis_free(an)
    end do
  end subroutine pass_fmg

  !> The baseline matrix of one factorisation: A with the Dirichlet (BOUND_FIXED) rows and
  !> columns decoupled (identity rows), the same sparsity pattern.
  function dirichlet_decoupled(sys) result(ar)
    type(primal_system_t), intent(in) :: sys
    type(csr_t) :: ar
    integer :: i, p
    ar = sys%a
    do i = 1, ar%n
      do p = ar%rowptr(i), ar%rowptr(i + 1) - 1
        if (sys%kind(i) == BOUND_FIXED .or. sys%kind(ar%col(p)) == BOUND_FIXED) ar%val(p) = 0.0_dp
      end do
      if (sys%kind(i) == BOUND_FIXED) ar%val(ar%diag(i)) = 1.0_dp
    end do
  end function dirichlet_decoupled
end module dualsig_bench_multigrid
