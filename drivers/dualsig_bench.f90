!> dualsig_bench: work-precision benchmark of the primal solvers (`make bench`).
!>
!> For the manufactured scenes p1_contact and p2_contact on the unit square, per level:
!> - the time of one projected SOR sweep divided by the time of one sparse matrix-vector
!>   product with the same matrix (medians over repeated timings in this run);
!> - projected SOR with omega = 1 (the paper's Gauss-Seidel with constraints) and with the
!>   automatic omega (Young's formula on a Lanczos estimate), each from a zero start and
!>   from the interpolated coarser solution (nested iteration): sweeps, seconds, error.
!> For the dual problem of P1 (p1_contact), per level: Uzawa (the paper's algorithm) and
!> the feasible active-set solver, iterations, seconds, the ratio of the whole dual solve
!> to ONE CHOLMOD analyse + factorisation of the Gram matrix A, err_q_Q and sqrt(est).
!> For the equilibrium dual of P2 (p2_contact), per level: the paper's plain Uzawa on (4.8)
!> (element-local LAPACK solves) and the augmented-Lagrangian variant (CHOLMOD), iterations,
!> seconds, the relative divergence defect of the solver's field and of the returned
!> (equilibrated) field, and ||grad u - lambda^h||.  The large P2 rows report the solver's
!> defect in the residual column.  The large section also prints a cold line per level
!> (cold_amg above 1e4 unknowns, else cold_schur or cold_aset: a zero start on that level's
!> mesh given as one level, method 'auto', against the same baseline);
!> `bin/dualsig_bench cold [level]` runs only cold 'schur', 'active_set' and 'multigrid'
!> (cold_amg: on the algebraic hierarchy) solves of both scenes at one level (10 by default).
!> `bin/dualsig_bench multigrid [lmax [lmax_base [scene]]]` runs only the multigrid section
!> (dualsig_bench_multigrid: TNNMG per level to lmax = 12 by default, baselines to 10,
!> scene p2_contact); the whole run ends with it and the duals section.
!> `bin/dualsig_bench duals [lmax [scene [dual_method]]]` (dualsig_bench_duals) runs only the
!> duals against the primal solve of the same mesh, pipeline defaults, levels to 9 (both
!> scenes and the factorising P2 dual 'augmented' by default).
!> `bin/dualsig_bench peers [lmax [scene]]` (dualsig_bench_peers, run by `make bench-peers`)
!> runs the dualsig side of the PETSc comparison: the multigrid grid sequence to lmax = 10 with
!> every level's QP exported to out/peers/, then cold solves of the finest QP.
!> Writes the tables to standard output and to out/bench_primal.csv, out/bench_dual_p1.csv,
!> out/bench_dual_p2.csv.
program dualsig_bench
  use dualsig_kinds, only: dp
  use dualsig_clock, only: wall_seconds, peak_memory_mb
  use dualsig_status, only: status_t
  use dualsig_mesh, only: mesh_t, mesh_h
  use dualsig_mesh_generate, only: mesh_rectangle
  use dualsig_mesh_refine, only: mesh_refine_uniform, mesh_prolongate_p1
  use dualsig_quadrature, only: tri_rule
  use dualsig_sparse, only: csr_matvec
  use dualsig_solver_psor, only: psor_settings_t, psor_result_t, psor_solve, psor_plan_t, psor_plan, psor_sweep
  use dualsig_qp_types, only: BOUND_FIXED
  use dualsig_spectral, only: jacobi_scaled_extremes, sor_omega_from_jacobi
  use dualsig_problem_primal, only: primal_system_t, primal_assemble, primal_constraints
  use dualsig_problem_kinds, only: PROBLEM_P1
  use dualsig_scenes, only: scene_t, scene_lookup
  use dualsig_estimate_errors, only: p1_error_norms
  use dualsig_sparse, only: csr_t
  use dualsig_sparse_direct, only: cholesky_t, cholesky_factor, cholesky_free, cholesky_solve
  use dualsig_assembly_dual_p1, only: assemble_dual_p1
  use dualsig_problem_dual_p1, only: dual_p1_settings_t, dual_p1_result_t, dual_p1_solve, dual_p1_ordering
  use dualsig_estimate_dual_p1, only: dual_p1_bounds_t, dual_p1_bounds, dual_p1_errors
  use dualsig_problem_dual_p2, only: dual_p2_settings_t, dual_p2_result_t, dual_p2_field_t, dual_p2_solve, &
                                    edge_end_ordering
  use dualsig_estimate_dual_p2, only: dual_p2_error
  use dualsig_solver_active_set, only: active_set_settings_t, active_set_result_t, active_set_solve
  use dualsig_sparse_direct, only: ORDERING_AMD, ORDERING_METIS, ORDERING_GEOMETRIC
  use dualsig_ordering_geometric, only: geometric_ordering
  use dualsig_assembly_equilibrium, only: equilibrium_map_t, equilibrium_map, equilibrium_elements, &
                                          assemble_equilibrium_global
  use dualsig_kinds, only: i8
  use dualsig_io_matrix_market, only: write_qp_matrix_market
  use dualsig_scene_problem, only: analysis_problem_set_scene
  use dualsig_analysis, only: analysis_problem_t, analysis_settings_t, analysis_t, level_result_t, &
                              analysis_start, analysis_next_level
  use dualsig_status, only: is_ok
  use dualsig_bench_multigrid, only: bench_multigrid, dirichlet_decoupled
  use dualsig_bench_peers, only: bench_peers
  use dualsig_bench_duals, only: bench_duals
  use dualsig_heap, only: heap_keep_freed
  implicit none

  integer, parameter :: max_level = 8          !! finest level (n = 2^level cells per side)
  integer, parameter :: max_level_gs = 6       !! omega = 1 is run up to this level only (sweeps x4 per level)
  integer, parameter :: timing_repeats = 21    !! timings per median
  real(dp), parameter :: tol = 1.0e-10_dp      !! KKT tolerance of every solve
  integer, parameter :: max_sweeps = 400000
  character(len=10), parameter :: scenes(2) = ['p1_contact', 'p2_contact']
  integer, parameter :: max_level_dual = 7        !! finest level of the dual benchmark
  integer, parameter :: max_level_uzawa = 6       !! Uzawa needs O(1/h) iterations: up to this level
  integer, parameter :: max_level_p2 = 7           !! finest level of the P2 dual benchmark
  integer, parameter :: max_level_large = 10       !! 1024^2 cells: 1.05e6 primal unknowns
  integer, parameter :: max_level_large_dual_p1 = 10
  integer, parameter :: max_level_large_dual_p2 = 10  !! 6.3e6 dual unknowns, about 10 GB
  integer, parameter :: first_level_reported = 5
  integer, parameter :: first_level_metis = 8      !! METIS analysis is reported from this level on
  integer, parameter :: first_level_fit = 7        !! levels used to fit time ~ N^p (smaller ones are noise)
  integer, parameter :: export_levels(2) = [8, 10] !! QPs exported for the PETSc comparison
  integer, parameter :: max_level_p2_uzawa = 3     !! plain Uzawa on (4.8): ~16x more iterations per level
  integer, parameter :: max_level_mg = 12          !! multigrid: 4097^2 nodes, 1.68e7 unknowns
  integer, parameter :: max_level_mg_base = 10     !! multigrid: the CHOLMOD baselines to this level
  integer, parameter :: max_level_duals = 9        !! duals: 2.6e5 primal unknowns (P2 dual about 10 s)

  type(scene_t) :: scene
  type(status_t) :: st
  type(mesh_t) :: mesh, finer
  type(primal_system_t) :: sys
  real(dp), allocatable :: u_prev(:), u_start(:), x(:), y(:)
  real(dp) :: t_mv, t_sw, omega_auto, lmin, lmax
  integer :: s, level, steps, csv
  character(len=32) :: sections(8) = ''
  integer :: nsections = 0
  character(len=*), parameter :: head = &
    '     scene  lvl     ndof  sweep/matvec  omega   start    sweeps   seconds      err_u_H1  kkt_residual'

  call heap_keep_freed()          ! as bin/dualsig: freed blocks reused (dualsig_heap)
  call execute_command_line('mkdir -p out')
  call get_sections()
  ! cold: only on request (`bin/dualsig_bench cold [level]`); the large section has a cold line per level
  if (nsections > 0) then
    if (sections(1) == 'cold') then
      call bench_cold()
      stop
    end if
    if (sections(1) == 'multigrid') then
      call multigrid_section()
      stop
    end if
    if (sections(1) == 'peers') then
      call peers_section()
      stop
    end if
    if (sections(1) == 'duals') then
      call duals_section()
      stop
    end if
  end if
  ! large_p2_full: the former name of large_p2 (when the P2 dual on the 10^6 mesh was optional)
  if (run_section('large') .or. run_section('large_p2') .or. run_section('large_p2_full')) &
    call bench_large('p2_contact', max_level_large, max_level_large_dual_p2)
  if (run_section('large') .or. run_section('large_p1')) &
    call bench_large('p1_contact', max_level_large, max_level_large_dual_p1)
  if (nsections > 0 .and. .not. run_section('primal')) then
    if (run_section('dual_p1')) call bench_dual_p1()
    if (run_section('dual_p2')) call bench_dual_p2()
    stop
  end if
  open (newunit=csv, file='out/bench_primal.csv', status='replace')
  write (csv, '(a)') 'scene,level,ndof,sweep_over_matvec,omega,start,sweeps,seconds,err_u_H1,kkt_residual'
  write (*, '(a)') 'dualsig_bench: projected SOR, KKT tolerance 1e-10, medians of 21 timings'
  write (*, '(a)') head
  do s = 1, size(scenes)
    call scene_lookup(scenes(s), scene, st)
    call mesh_rectangle(mesh, 0.0_dp, 1.0_dp, 0.0_dp, 1.0_dp, 2, 2, 'right', st)
    do level = 1, max_level
      if (level > 1) then
        call mesh_refine_uniform(mesh, finer, st)
        ! nested start: the previous level's solution interpolated on the new mesh
        if (allocated(u_start)) deallocate (u_start)
        allocate (u_start(finer%nnode))
        call mesh_prolongate_p1(mesh, finer, u_prev, u_start)
        mesh = finer
      end if
      call primal_assemble(mesh, scene%problem, scene%f, tri_rule(5), sys, st=st)
      call primal_constraints(mesh, scene%problem, scene%gamma_u_markers, scene%gamma_a_markers, &
                              sys%kind, sys%bnd, st)
      allocate (x(mesh%nnode), y(mesh%nnode))
      x = 1.0_dp
      t_mv = median_matvec()
      t_sw = median_sweep()
      deallocate (x, y)
      call jacobi_scaled_extremes(sys%a, sys%kind /= BOUND_FIXED, 400, 1.0e-3_dp, lmin, lmax, steps, st)
      omega_auto = sor_omega_from_jacobi(lmin, lmax)
      if (level >= 3) then
        if (level <= max_level_gs) then
          call run(1.0_dp, .false.)
          call run(1.0_dp, .true.)
        end if
        call run(omega_auto, .true.)
      end if
      call run(omega_auto, .false.)          ! last: its solution starts the next level
    end do
    if (allocated(u_prev)) deallocate (u_prev)
    if (allocated(u_start)) deallocate (u_start)
  end do
  close (csv)
  write (*, '(a)') 'dualsig_bench: table written to out/bench_primal.csv'
  if (run_section('dual_p1')) call bench_dual_p1()
  if (run_section('dual_p2')) call bench_dual_p2()
  if (nsections == 0) then
    call bench_multigrid(max_level_mg, max_level_mg_base, 'p2_contact')
    call bench_duals(max_level_duals, 'p1_contact')
    call bench_duals(max_level_duals, 'p2_contact')
    call bench_duals(max_level_duals, 'p2_contact', 'augmented')
  end if

contains

  !> `multigrid [lmax [lmax_base [scene]]]`: the multigrid section alone.
  subroutine multigrid_section()
    integer :: lmax, lbase, ios
    character(len=32) :: arg, name
    lmax = max_level_mg
    lbase = max_level_mg_base
    name = 'p2_contact'
    if (nsections >= 2) read (sections(2), *, iostat=ios) lmax
    if (nsections >= 3) read (sections(3), *, iostat=ios) lbase
    if (nsections >= 4) name = sections(4)
    arg = name
    call bench_multigrid(lmax, lbase, trim(arg))
  end subroutine multigrid_section

  !> `duals [lmax [scene [dual_method]]]`: the cost of the duals against the primal solve
  !> (both scenes, and P2 by the factorising 'augmented' too, without a scene).
  subroutine duals_section()
    integer :: lmax, ios
    lmax = max_level_duals
    if (nsections >= 2) read (sections(2), *, iostat=ios) lmax
    if (nsections >= 4) then
      call bench_duals(lmax, trim(sections(3)), trim(sections(4)))
    else if (nsections >= 3) then
      call bench_duals(lmax, trim(sections(3)))
    else
      call bench_duals(lmax, 'p1_contact')
      call bench_duals(lmax, 'p2_contact')
      call bench_duals(lmax, 'p2_contact', 'augmented')
    end if
  end subroutine duals_section

  !> `peers [lmax [scene]]`: the dualsig side of the PETSc comparison (make bench-peers).
  subroutine peers_section()
    integer :: lmax, ios
    character(len=32) :: name
    lmax = 10
    name = 'p2_contact'
    if (nsections >= 2) read (sections(2), *, iostat=ios) lmax
    if (nsections >= 3) name = sections(3)
    call bench_peers(lmax, trim(name))
  end subroutine peers_section

  !> Sections to run: the command-line arguments (primal, dual_p1, dual_p2, large, or
  !> large_p1 / large_p2 for one scene of `large`), all without arguments; `cold [level]`
  !> alone runs bench_cold.
  subroutine get_sections()
    integer :: k
    nsections = min(command_argument_count(), size(sections))
    do k = 1, nsections
      call get_command_argument(k, sections(k))
    end do
  end subroutine get_sections

  logical function run_section(name)
    character(len=*), intent(in) :: name
    run_section = nsections == 0 .or. any(sections(1:nsections) == name)
  end function run_section

  !> Work-precision and scaling up to ~1e6 primal unknowns for one manufactured scene:
  !> grid sequencing; per level the active-set primal solve (warm start from the
  !> interpolated coarser solution) against ONE analyse + factorise + solve of the same
  !> matrix without the Signorini constraints (AMD; METIS reported beside it), the error,
  !> peak memory; the feasible dual solve (P1: active set in rotated variables, P2:
  !> augmented Lagrangian) against one analyse + factorisation of its own matrix.
  subroutine bench_large(scene_name, lmax, lmax_dual)
    character(len=*), intent(in) :: scene_name
    integer, intent(in) :: lmax, lmax_dual
    type(analysis_problem_t) :: pb
    type(analysis_settings_t) :: aset_pipeline
    type(analysis_t) :: an
    type(level_result_t) :: res
    type(csr_t) :: ar, ad
    type(cholesky_t) :: chol
    type(dual_p1_result_t) :: d1res
    type(dual_p2_result_t) :: d2res
    real(dp), allocatable :: u(:), x(:), bd(:)
    real(dp) :: t0, tp, tb, tbm, tbn, td, tdb, tdba, err, err_lambda, nlog(20), tlog(20, 3)
    integer :: lcsv, i, p, nfit, ord
    integer, allocatable :: perm(:)
    integer(i8) :: nnz_amd, nnz_metis, nnz_nd
    real(dp) :: fl_amd, fl_metis, fl_nd
    character(len=12) :: dual_name
    character(len=64) :: qp_name
    open (newunit=lcsv, file='out/bench_large_' // scene_name // '.csv', status='replace')
    write (lcsv, '(a)') 'scene,level,n,solver,seconds,iterations,factorisations,bordered,baseline_s,ratio,' // &
      'error,residual,peak_mb,nnz_amd,nnz_metis,baseline_metis_s,baseline_amd_s,ratio_amd,nnz_nd,' // &
      'flops_amd,flops_nd,flops_metis'
    write (*, '(/,a)') 'dualsig_bench: work-precision and scaling, ' // scene_name // &
      ' (grid sequencing; geometric nested dissection from 1e4 unknowns, AMD below, its time included; baseline = one' // &
      ' ordering+analyse+factorise+solve of the unconstrained matrix with the same ordering; amd = the same with AMD)'
    write (*, '(a)') '  lvl         N     solver   iters fact bord   seconds  baseline   ratio       error    residual' // &
      '   peak MB  nnzL(amd)  nnzL(metis) metis_s   amd_s ratio_amd   nnzL(nd)'
    call scene_lookup(scene_name, scene, st)
    call mesh_rectangle(mesh, 0.0_dp, 1.0_dp, 0.0_dp, 1.0_dp, 2, 2, 'right', st)
    nfit = 0
    dual_name = merge('active_set', 'augmented ', scene%problem == PROBLEM_P1)
    ! the pipeline: grid sequencing, the active set with nested dissection from 1e4 unknowns,
    ! the feasible dual with the solvers' own tolerance; the P2 bounds are not timed here
    ! (bench_dual_p2 and the driver cover them), only the field and its error
    call analysis_problem_set_scene(pb, scene)
    pb%mesh = mesh
    aset_pipeline%levels = lmax
    aset_pipeline%method = 'active_set'
    aset_pipeline%max_iter = 100
    aset_pipeline%ordering = ORDERING_GEOMETRIC
    aset_pipeline%dual = lmax_dual >= first_level_reported
    aset_pipeline%dual_tol_h2 = 0.0_dp
    aset_pipeline%bounds = scene%problem == PROBLEM_P1
    aset_pipeline%keep_fields = .true.
    ! the baselines below factorise the matrix of the paper's space: time the same space
    aset_pipeline%dual_space = 'paper'
    call analysis_start(an, pb, aset_pipeline, st)
    do level = 1, lmax
      call analysis_next_level(an, res, st)
      if (.not. is_ok(st)) then
        write (*, '(a,i0,a)') 'dualsig_bench: level ', level, ': ' // st%msg
        exit
      end if
      tp = res%primal_seconds
      if (level < first_level_reported) cycle
      ! the level's matrix again (untimed), for the baselines and the QP export
      mesh = an%mesh
      u = res%u
      call primal_assemble(mesh, scene%problem, scene%f, tri_rule(5), sys, st=st)
      call primal_constraints(mesh, scene%problem, scene%gamma_u_markers, scene%gamma_a_markers, &
                              sys%kind, sys%bnd, st)
      ! baseline: the same matrix with only the Dirichlet rows, one analyse+factorise+solve
      ar = dirichlet_decoupled(sys)
      allocate (x(ar%n))
      t0 = wall_seconds()
      call cholesky_factor(ar, chol, st, ORDERING_AMD)
      call cholesky_solve(chol, sys%load, x, st)
      tb = wall_seconds() - t0
      nnz_amd = chol%nnz_factor
      fl_amd = chol%flops
      call cholesky_free(chol)
      t0 = wall_seconds()
      call geometric_ordering(mesh%xy, ar, ord, perm, st)
      call cholesky_factor(ar, chol, st, ord, perm)
      call cholesky_solve(chol, sys%load, x, st)
      tbn = wall_seconds() - t0
      nnz_nd = chol%nnz_factor
      fl_nd = chol%flops
      call cholesky_free(chol)
      nnz_metis = 0
      fl_metis = 0.0_dp
      tbm = 0.0_dp
      if (level >= first_level_metis) then
        t0 = wall_seconds()
        call cholesky_factor(ar, chol, st, ORDERING_METIS)
        call cholesky_solve(chol, sys%load, x, st)
        tbm = wall_seconds() - t0
        nnz_metis = chol%nnz_factor
        fl_metis = chol%flops
        call cholesky_free(chol)
      end if
      deallocate (x)
      if (any(level == export_levels)) then
        write (qp_name, '(a,i0)') 'out/qp_' // scene_name // '_l', level
        call write_qp_matrix_market(trim(qp_name), sys%a, sys%load, sys%kind, sys%bnd, u, st)
      end if
      err = res%err_energy
      write (*, '(i5,i10,a11,i8,i5,i5,2f10.3,f8.2,2es12.3,f10.0,2i11,f8.2,f8.3,f8.2,i11)') level, mesh%nnode, &
        'active_set', res%primal_iters, res%primal_factorisations, res%primal_bordered, tp, tbn, tp / tbn, err, &
        res%kkt_residual, peak_memory_mb(), nnz_amd, nnz_metis, tbm, tb, tp / tb, nnz_nd
      write (lcsv, '(a,",",i0,",",i0,",",a,",",es12.4,",",i0,",",i0,",",i0,3(",",es12.4),",",es12.4,",",f10.1,2(",",i0),' // &
        '3(",",es12.4),",",i0,3(",",es12.4))') scene_name, level, mesh%nnode, 'active_set', tp, res%primal_iters, &
        res%primal_factorisations, res%primal_bordered, tbn, tp / tbn, err, res%kkt_residual, peak_memory_mb(), &
        nnz_amd, nnz_metis, &
        tbm, tb, tp / tb, nnz_nd, fl_amd, fl_nd, fl_metis
      write (*, '(a,3es11.3,a,f6.3)') '       factor flops (CHOLMOD): amd, baseline ordering, metis =', fl_amd, fl_nd, &
        fl_metis, ';  baseline / amd =', fl_nd / fl_amd
      ! a cold solve of the same mesh given at its final size (one level, zero start, the
      ! default primal method) against the same baseline
      call cold_line(pb, mesh, 'auto', level, tbn, lcsv)
      flush (6)
      if (level >= first_level_fit) then
        nfit = nfit + 1
        nlog(nfit) = log(real(mesh%nnode, dp))
        tlog(nfit, 1) = log(tp)
        tlog(nfit, 2) = log(tbn)
        tlog(nfit, 3) = 0.0_dp
      end if
      if (level > lmax_dual) cycle
      ! the feasible dual, against one analyse + factorisation of its own matrix
      if (scene%problem == PROBLEM_P1) then
        allocate (bd(2 * mesh%nnode))
        call assemble_dual_p1(mesh, scene%f, tri_rule(5), ad, bd, st=st)
        t0 = wall_seconds()
        call cholesky_factor(ad, chol, st, ORDERING_AMD)
        tdba = wall_seconds() - t0
        call cholesky_free(chol)
        t0 = wall_seconds()
        call dual_p1_ordering(mesh, ad, ORDERING_GEOMETRIC, ord, perm, st)
        call cholesky_factor(ad, chol, st, ord, perm)
        tdb = wall_seconds() - t0
        call cholesky_free(chol)
        deallocate (bd)
        td = res%dual_seconds
        d1res = res%dual_p1
        write (*, '(i5,i10,a11,i8,i5,i5,2f10.3,f8.2,2es12.3,f10.0,30x,f8.3,f8.2)') level, 2 * mesh%nnode, 'dual_p1', &
          d1res%iterations, d1res%factorisations, d1res%lowrank_solves, td, tdb, td / tdb, sqrt(res%est), &
          d1res%residual, peak_memory_mb(), tdba, td / tdba
        write (lcsv, '(a,",",i0,",",i0,",",a,",",es12.4,",",i0,",",i0,",",i0,3(",",es12.4),",",es12.4,",",f10.1,' // &
          '",0,0,0",2(",",es12.4),",0,0,0,0")') scene_name, level, 2 * mesh%nnode, 'dual_p1', td, d1res%iterations, &
          d1res%factorisations, d1res%lowrank_solves, tdb, td / tdb, sqrt(res%est), d1res%residual, peak_memory_mb(), &
          tdba, td / tdba
      else
        td = res%dual_seconds
        d2res = res%dual_p2
        err_lambda = dual_p2_error(mesh, res%lambda, scene%f, scene%grad_u, tri_rule(8))
        call p2_dual_baselines(mesh, ad, tdba, tdb)
        write (*, '(i5,i10,a11,i8,i5,i5,2f10.3,f8.2,2es12.3,f10.0,30x,f8.3,f8.2)') level, ad%n, 'dual_p2', &
          d2res%iterations, d2res%factorisations, 0, td, tdb, td / tdb, &
          err_lambda, d2res%defect_solver, peak_memory_mb(), tdba, td / tdba
        write (*, '(a,4f8.3,a)') '       profile of the dual solve (s): particular field, elements, loads, solver =', &
          d2res%seconds_particular, d2res%seconds_elements, d2res%seconds_loads, d2res%seconds_solver
        write (*, '(a,a,a,i0,a,2es10.2)') '       inner solver ', trim(d2res%inner), ': ', d2res%inner_iterations, &
          ' inner iterations in all; divergence defect of the solver''s / the returned field:', &
          d2res%defect_solver, d2res%defect
        write (lcsv, '(a,",",i0,",",i0,",",a,",",es12.4,",",i0,",",i0,",",i0,3(",",es12.4),",",es12.4,",",f10.1,' // &
          '",0,0,0",2(",",es12.4),",0,0,0,0")') scene_name, level, ad%n, 'dual_p2', td, d2res%iterations, d2res%factorisations, &
          0, tdb, td / tdb, err_lambda, d2res%defect_solver, peak_memory_mb(), &
          tdba, td / tdba
      end if
      if (level >= first_level_fit) tlog(nfit, 3) = log(td)
      flush (6)
    end do
    close (lcsv)
    write (*, '(a,f6.3,a,f6.3,a)') '  fitted exponent p in time ~ N^p (levels >= 7): active set ', &
      slope(nlog(1:nfit), tlog(1:nfit, 1)), ', one factorisation ', slope(nlog(1:nfit), tlog(1:nfit, 2)), &
      '  (N = primal unknowns)'
    if (count(tlog(1:nfit, 3) /= 0.0_dp) >= 2) write (*, '(a,a,a,f6.3)') '  fitted exponent, dual (', &
      trim(dual_name), '): ', slope(pack(nlog(1:nfit), tlog(1:nfit, 3) /= 0.0_dp), pack(tlog(1:nfit, 3), &
      tlog(1:nfit, 3) /= 0.0_dp))
    write (*, '(a)') 'dualsig_bench: table written to out/bench_large_' // scene_name // '.csv'
    if (allocated(u)) deallocate (u)
  end subroutine bench_large

  !> A cold solve (zero start, the mesh as one level, no dual) of the primal QP on `mesh`
  !> with `method` through the pipeline, printed as a 'cold' line with its ratio to the
  !> baseline `tbase` (one ordering + analyse + factorise + solve); also to csv unit `lcsv`.
  subroutine cold_line(pb, mesh_level, method, level, tbase, lcsv)
    type(analysis_problem_t), intent(in) :: pb
    type(mesh_t), intent(in) :: mesh_level
    character(len=*), intent(in) :: method
    integer, intent(in) :: level, lcsv
    real(dp), intent(in) :: tbase
    type(analysis_problem_t) :: pc
    type(analysis_settings_t) :: set
    type(analysis_t) :: an_cold
    type(level_result_t) :: rc
    type(status_t) :: stc
    character(len=16) :: label
    pc = pb
    pc%mesh = mesh_level
    set%levels = 1
    set%method = method
    set%max_iter = 100
    set%ordering = ORDERING_GEOMETRIC
    set%dual = .false.
    call analysis_start(an_cold, pc, set, stc)
    if (is_ok(stc)) call analysis_next_level(an_cold, rc, stc)
    if (.not. is_ok(stc)) then
      write (*, '(a,i0,a)') 'dualsig_bench: cold solve at level ', level, ': ' // trim(stc%msg)
      return
    end if
    label = 'cold_' // trim(rc%primal_method)
    if (rc%primal_method == 'active_set') label = 'cold_aset'       ! fits the solver column
    if (rc%primal_method == 'multigrid_amg') label = 'cold_amg'
    write (*, '(i5,i10,a11,i8,i5,i5,2f10.3,f8.2,2es12.3,f10.0)') level, mesh_level%nnode, trim(label), rc%primal_iters, &
      rc%primal_factorisations, rc%primal_bordered, rc%primal_seconds, tbase, rc%primal_seconds / tbase, rc%err_energy, &
      rc%kkt_residual, peak_memory_mb()
    write (lcsv, '(a,",",i0,",",i0,",",a,",",es12.4,",",i0,",",i0,",",i0,3(",",es12.4),",",es12.4,",",f10.1,' // &
      '",0,0,0,0,0,0,0,0,0")') trim(pb_scene_name()), level, mesh_level%nnode, trim(label), rc%primal_seconds, &
      rc%primal_iters, rc%primal_factorisations, rc%primal_bordered, tbase, rc%primal_seconds / tbase, rc%err_energy, &
      rc%kkt_residual, peak_memory_mb()
  end subroutine cold_line

  !> The name of the scene being benchmarked.
  function pb_scene_name() result(name)
    character(len=:), allocatable :: name
    name = trim(scene%name)
  end function pb_scene_name

  !> Cold solves at one level (`bin/dualsig_bench cold [level]`, level 10 by default: 1.05e6
  !> unknowns) of p2_contact and p1_contact: the baseline (geometric nested dissection +
  !> analyse + factorise + solve of the matrix with only the Dirichlet rows), then cold
  !> solves with 'schur', 'active_set' and 'multigrid' (on one level: TNNMG on the algebraic
  !> hierarchy of smoothed aggregation, setup included; 'cold_amg') through the pipeline,
  !> all in this run.
  subroutine bench_cold()
    integer :: lvl, s2, i, p, ord, ios, lcsv
    character(len=16) :: arg
    type(analysis_problem_t) :: pb
    type(csr_t) :: ar
    type(cholesky_t) :: chol
    real(dp), allocatable :: xb(:)
    integer, allocatable :: perm(:)
    real(dp) :: t0, tbn
    lvl = max_level_large
    if (command_argument_count() >= 2) then
      call get_command_argument(2, arg)
      read (arg, *, iostat=ios) lvl
      if (ios /= 0) lvl = max_level_large
    end if
    open (newunit=lcsv, file='out/bench_cold.csv', status='replace')
    write (lcsv, '(a)') 'scene,level,n,solver,seconds,iterations,factorisations,bordered,baseline_s,ratio,' // &
      'error,residual,peak_mb,unused1,unused2,unused3,unused4,unused5,unused6,unused7,unused8,unused9'
    write (*, '(/,a)') 'dualsig_bench: cold solves (zero start, one level) against one ordering + analyse + ' // &
      'factorise + solve (geometric nested dissection)'
    write (*, '(a)') '  lvl         N     solver   iters fact bord   seconds  baseline   ratio       error    residual   peak MB'
    do s2 = 1, size(scenes)
      call scene_lookup(scenes(s2), scene, st)
      call mesh_rectangle(mesh, 0.0_dp, 1.0_dp, 0.0_dp, 1.0_dp, 2**lvl, 2**lvl, 'right', st)
      call analysis_problem_set_scene(pb, scene)
      call primal_assemble(mesh, scene%problem, scene%f, tri_rule(5), sys, st=st)
      call primal_constraints(mesh, scene%problem, scene%gamma_u_markers, scene%gamma_a_markers, &
                              sys%kind, sys%bnd, st)
      ar = dirichlet_decoupled(sys)
      allocate (xb(ar%n))
      t0 = wall_seconds()
      call geometric_ordering(mesh%xy, ar, ord, perm, st)
      call cholesky_factor(ar, chol, st, ord, perm)
      call cholesky_solve(chol, sys%load, xb, st)
      tbn = wall_seconds() - t0
      call cholesky_free(chol)
      deallocate (xb)
      call cold_line(pb, mesh, 'schur', lvl, tbn, lcsv)
      call cold_line(pb, mesh, 'active_set', lvl, tbn, lcsv)
      call cold_line(pb, mesh, 'multigrid', lvl, tbn, lcsv)    ! algebraic hierarchy (cold_amg)
      flush (6)
    end do
    close (lcsv)
    write (*, '(a)') 'dualsig_bench: table written to out/bench_cold.csv'
  end subroutine bench_cold

  !> The baselines of the P2 dual: the matrix of its global edge-end fluxes (ad), one AMD
  !> analyse + factorisation (tdba seconds) and one with the nested-dissection ordering of
  !> the edge-end fluxes (tdb seconds).
  subroutine p2_dual_baselines(mesh, ad, tdba, tdb)
    type(mesh_t), intent(in) :: mesh
    type(csr_t), intent(out) :: ad
    real(dp), intent(out) :: tdba, tdb
    type(equilibrium_map_t) :: map
    type(cholesky_t) :: chol
    type(status_t) :: st
    real(dp), allocatable :: c(:,:,:), ae(:,:,:), dd(:,:)
    integer, allocatable :: perm(:)
    real(dp) :: t0
    integer :: ord
    call equilibrium_elements(mesh, c, ae, dd, st)
    call equilibrium_map(mesh, map, st=st)
    call assemble_equilibrium_global(map, ae, ad, st=st)
    t0 = wall_seconds()
    call cholesky_factor(ad, chol, st, ORDERING_AMD)
    tdba = wall_seconds() - t0
    call cholesky_free(chol)
    t0 = wall_seconds()
    call edge_end_ordering(mesh, ad, ord, perm, st)
    call cholesky_factor(ad, chol, st, ord, perm)
    tdb = wall_seconds() - t0
    call cholesky_free(chol)
  end subroutine p2_dual_baselines

  !> Least-squares slope of y against x.
  pure real(dp) function slope(x, y)
    real(dp), intent(in) :: x(:), y(:)
    real(dp) :: xm, ym
    xm = sum(x) / size(x)
    ym = sum(y) / size(y)
    slope = sum((x - xm) * (y - ym)) / max(sum((x - xm)**2), tiny(1.0_dp))
  end function slope

  !> Equilibrium dual of P2: plain Uzawa (4.8) against the augmented-Lagrangian variant.
  subroutine bench_dual_p2()
    type(dual_p2_settings_t) :: dset
    type(dual_p2_result_t) :: dres
    type(dual_p2_field_t) :: field
    logical, allocatable :: is_gamma_a(:)
    real(dp) :: t0, secs, err
    integer :: m, dcsv
    ! the paper's Uzawa, and the augmented Lagrangian with each inner solver
    character(len=9) :: methods(3) = ['uzawa    ', 'augmented', 'augmented']
    character(len=10) :: inners(3) = ['-         ', 'active_set', 'schur     ']
    open (newunit=dcsv, file='out/bench_dual_p2.csv', status='replace')
    write (dcsv, '(a)') 'level,ntri,method,inner,iterations,factorisations,seconds,defect_solver,defect,err_lambda'
    write (*, '(/,a)') 'dualsig_bench: equilibrium dual of P2 (p2_contact)'
    write (*, '(a)') '  lvl     ntri      method      inner   iters  factor   seconds  solver_defect     div_defect' // &
      '   ||grad u - lambda_h||'
    call scene_lookup('p2_contact', scene, st)
    call mesh_rectangle(mesh, 0.0_dp, 1.0_dp, 0.0_dp, 1.0_dp, 2, 2, 'right', st)
    do level = 1, max_level_p2
      if (level > 1) then
        call mesh_refine_uniform(mesh, finer, st)
        mesh = finer
      end if
      if (level < 2) cycle
      is_gamma_a = mesh%bedge_marker == 1
      do m = 1, size(methods)
        if (methods(m) == 'uzawa' .and. level > max_level_p2_uzawa) cycle
        dset%method = methods(m)
        if (m > 1) dset%inner = inners(m)
        dset%tol = max(1.0e-10_dp, 1.0e-4_dp * (mesh_h(mesh) / sqrt(2.0_dp))**2)
        dset%max_iter = 1000000
        t0 = wall_seconds()
        call dual_p2_solve(mesh, scene%f, is_gamma_a, 0.0_dp, dset, field, dres, st, scene%x_breaks(1:1))
        secs = wall_seconds() - t0
        err = dual_p2_error(mesh, field, scene%f, scene%grad_u, tri_rule(12))
        write (*, '(i5,i9,a12,a11,i8,i8,f10.3,2es15.3,es24.4)') level, mesh%ntri, trim(methods(m)), &
          trim(inners(m)), dres%iterations, dres%factorisations, secs, dres%defect_solver, dres%defect, err
        write (dcsv, '(i0,",",i0,",",a,",",a,",",i0,",",i0,",",es12.4,2(",",es12.4),",",es14.6)') level, mesh%ntri, &
          trim(methods(m)), trim(inners(m)), dres%iterations, dres%factorisations, secs, dres%defect_solver, dres%defect, err
        flush (6)
      end do
    end do
    close (dcsv)
    write (*, '(a)') 'dualsig_bench: table written to out/bench_dual_p2.csv'
  end subroutine bench_dual_p2

  !> Dual problem of P1: Uzawa and the active-set solver against one factorisation of A.
  subroutine bench_dual_p1()
    type(dual_p1_settings_t) :: dset
    type(dual_p1_result_t) :: dres
    type(dual_p1_bounds_t) :: bounds
    type(csr_t) :: a
    type(cholesky_t) :: chol
    real(dp), allocatable :: q(:), b(:), u(:)
    real(dp) :: t0, t_fact, times(3), secs, eq, ediv, eqq
    integer :: k, m, dcsv
    type(psor_settings_t) :: set
    type(psor_result_t) :: res
    character(len=10) :: methods(2) = ['uzawa     ', 'active_set']
    open (newunit=dcsv, file='out/bench_dual_p1.csv', status='replace')
    write (dcsv, '(a)') 'level,ndof_dual,method,iterations,seconds,factorisation_s,ratio,err_q_Q,sqrt_est'
    write (*, '(/,a)') 'dualsig_bench: dual problem of P1 (p1_contact), feasible q, medians of 3 factorisations'
    write (*, '(a)') '  lvl  ndof_dual      method   iters   seconds  factor_s  solve/factor      err_q_Q   sqrt(est)'
    call scene_lookup('p1_contact', scene, st)
    call mesh_rectangle(mesh, 0.0_dp, 1.0_dp, 0.0_dp, 1.0_dp, 2, 2, 'right', st)
    do level = 1, max_level_dual
      if (level > 1) then
        call mesh_refine_uniform(mesh, finer, st)
        mesh = finer
      end if
      if (level < 3) cycle
      ! the primal solution for the bounds
      call primal_assemble(mesh, scene%problem, scene%f, tri_rule(5), sys, st=st)
      call primal_constraints(mesh, scene%problem, scene%gamma_u_markers, scene%gamma_a_markers, &
                              sys%kind, sys%bnd, st)
      call jacobi_scaled_extremes(sys%a, sys%kind /= BOUND_FIXED, 400, 1.0e-3_dp, lmin, lmax, steps, st)
      set%omega = sor_omega_from_jacobi(lmin, lmax)
      set%tol = tol
      allocate (u(mesh%nnode), source=0.0_dp)
      call psor_solve(sys%a, sys%load, sys%kind, sys%bnd, u, set, res, st)
      ! one analyse + factorisation of the Gram matrix A (median of 3)
      allocate (b(2 * mesh%nnode))
      call assemble_dual_p1(mesh, scene%f, tri_rule(5), a, b, st=st)
      do k = 1, 3
        t0 = wall_seconds()
        call cholesky_factor(a, chol, st)
        times(k) = wall_seconds() - t0
        call cholesky_free(chol)
      end do
      t_fact = median(times)
      do m = 1, 2
        if (methods(m) == 'uzawa' .and. level > max_level_uzawa) cycle
        dset%method = methods(m)
        dset%tol = max(1.0e-10_dp, 1.0e-4_dp * (mesh_h(mesh) / sqrt(2.0_dp))**2)
        t0 = wall_seconds()
        call dual_p1_solve(mesh, scene%f, tri_rule(5), dset, q, dres, st)
        secs = wall_seconds() - t0
        call dual_p1_bounds(mesh, u, q, scene%f, tri_rule(16), bounds, st=st)
        call dual_p1_errors(mesh, q, scene%f, scene%u, scene%grad_u, tri_rule(16), eq, ediv, eqq)
        write (*, '(i5,i11,a12,i8,f10.3,f10.3,f14.2,es13.4,es12.4)') level, 2 * mesh%nnode, trim(methods(m)), &
          dres%iterations, secs, t_fact, secs / t_fact, eqq, sqrt(bounds%est)
        write (dcsv, '(i0,",",i0,",",a,",",i0,3(",",es12.4),2(",",es14.6))') level, 2 * mesh%nnode, &
          trim(methods(m)), dres%iterations, secs, t_fact, secs / t_fact, eqq, sqrt(bounds%est)
        flush (6)
      end do
      deallocate (u, b)
    end do
    close (dcsv)
    write (*, '(a)') 'dualsig_bench: table written to out/bench_dual_p1.csv'
  end subroutine bench_dual_p1

  !> Solve from zero (nested = .false.) or from u_start; the solution is kept in u_prev.
  subroutine run(omega, nested)
    real(dp), intent(in) :: omega
    logical, intent(in) :: nested
    type(psor_settings_t) :: set
    type(psor_result_t) :: res
    type(status_t) :: st_solve
    real(dp), allocatable :: u(:)
    real(dp) :: t0, secs, e0, e1, err
    character(len=6) :: start
    allocate (u(mesh%nnode), source=0.0_dp)
    start = 'zero'
    if (nested .and. allocated(u_start)) then
      u = u_start
      start = 'nested'
    end if
    set%omega = omega
    set%tol = tol
    set%max_iter = max_sweeps
    t0 = wall_seconds()
    call psor_solve(sys%a, sys%load, sys%kind, sys%bnd, u, set, res, st_solve)
    secs = wall_seconds() - t0
    call p1_error_norms(mesh, u, scene%u, scene%grad_u, tri_rule(16), e0, e1)
    err = e1
    if (scene%problem == PROBLEM_P1) err = sqrt(e0**2 + e1**2)
    u_prev = u
    if (level < 3) return
    write (*, '(a10,i5,i9,f14.2,f7.3,a8,i10,f10.3,es14.4,es14.3)') trim(scene%name), level, &
      count(sys%kind /= BOUND_FIXED), t_sw / t_mv, omega, trim(start), res%iterations, secs, err, &
      res%kkt_residual
    write (csv, '(a,",",i0,",",i0,",",es12.4,",",f8.5,",",a,",",i0,",",es12.4,",",es16.8,",",es12.4)') &
      trim(scene%name), level, count(sys%kind /= BOUND_FIXED), t_sw / t_mv, omega, trim(start), &
      res%iterations, secs, err, res%kkt_residual
    flush (6)
  end subroutine run

  !> Median time of one y = A x.
  real(dp) function median_matvec() result(t)
    real(dp) :: times(timing_repeats), t0
    integer :: k, r, reps
    reps = max(1, 2000000 / max(1, size(sys%a%val)))
    do k = 1, timing_repeats
      t0 = wall_seconds()
      do r = 1, reps
        call csr_matvec(sys%a, x, y)
        x(1) = x(1) + 1.0e-300_dp * y(1)
      end do
      times(k) = (wall_seconds() - t0) / reps
    end do
    t = median(times)
  end function median_matvec

  !> Median time of one projected SOR sweep with the same matrix (as psor_solve does it).
  real(dp) function median_sweep() result(t)
    real(dp) :: times(timing_repeats), t0
    integer :: k, r, reps
    type(psor_plan_t) :: plan
    call psor_plan(sys%a, sys%kind, sys%bnd, 1.0_dp, plan)
    reps = max(1, 2000000 / max(1, size(sys%a%val)))
    do k = 1, timing_repeats
      t0 = wall_seconds()
      do r = 1, reps
        call psor_sweep(sys%a, sys%load, plan, x)
      end do
      times(k) = (wall_seconds() - t0) / reps
    end do
    t = median(times)
  end function median_sweep

  real(dp) function median(v)
    real(dp), intent(in) :: v(:)
    real(dp) :: w(size(v)), tmp
    integer :: i, j
    w = v
    do i = 2, size(w)
      tmp = w(i)
      j = i - 1
      do while (j >= 1)
        if (w(j) <= tmp) exit
        w(j + 1) = w(j)
        j = j - 1
      end do
      w(j + 1) = tmp
    end do
    median = w((size(w) + 1) / 2)
  end function median

end program dualsig_bench
