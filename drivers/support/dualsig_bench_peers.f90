!> The dualsig side of the fair PETSc comparison (`bin/dualsig_bench peers [lmax [scene]]`,
!> run by `make bench-peers` right before bench/petsc_peers.py --fair, issue 16 item 4).
!>
!> On the refinement hierarchy of the unit square (2 x 2 cells refined uniformly; level l has
!> (2^l + 1)^2 nodes), KKT tolerance 1e-10, no dual analysis:
!>  1. the whole grid sequence with method 'multigrid' (level 1 by 'auto', each level started
!>     from the interpolated coarser solution): per level the solve's seconds and V-cycles.
!>     After each level's solve (untimed) its QP is exported in binary to
!>     out/peers/<scene>_l<level>.bin with the prolongation from the level before, so that
!>     PETSc can run the same grid sequence;
!>  2. cold solves of the finest level's QP from x = 0: 'multigrid' on the same hierarchy
!>     (its cold start is nested iteration on the restricted QPs: it uses the geometric
!>     hierarchy, which the QP alone does not carry), and on the finest mesh given as one level
!>     (no hierarchy, the QP and the node coordinates only): 'auto', i.e. multigrid on the
!>     algebraic hierarchy built from the matrix ('multigrid_amg', what a user with a fine
!>     Gmsh mesh gets), and 'schur' (skipped above max_level_schur, where one CHOLMOD
!>     factorisation no longer fits the machine).
!> Rows to standard output and out/peers/<scene>_dualsig.csv (read by petsc_peers.py --fair).
!>
!> Binary format (stream, native little-endian), all integers 32-bit:
!>   'DSQP0001', n, nnz, ne, rowptr(n+1), col(nnz), val(nnz) (float64), F(n), bnd(n), x(n)
!>   (float64), kind(n), ends(2, ne): fine node nc + e (nc = n - ne) is the midpoint of the
!>   coarse nodes ends(1:2, e) of the level before (ne = 0 on level 1).
module dualsig_bench_peers
  use dualsig_kinds, only: dp
  use dualsig_clock, only: wall_seconds, peak_memory_mb
  use dualsig_status, only: status_t, is_ok
  use dualsig_mesh_generate, only: mesh_rectangle
  use dualsig_quadrature, only: tri_rule
  use dualsig_sparse_direct, only: ORDERING_GEOMETRIC
  use dualsig_problem_primal, only: primal_system_t, primal_assemble, primal_constraints
  use dualsig_scenes, only: scene_t, scene_lookup
  use dualsig_solver_multigrid, only: mg_settings_t, mg_result_t, multigrid_solve
  use dualsig_scene_problem, only: analysis_problem_set_scene
  use dualsig_analysis, only: analysis_problem_t, analysis_settings_t, analysis_t, level_result_t, &
                              analysis_start, analysis_next_level, analysis_free
  implicit none
  private

  public :: bench_peers

  real(dp), parameter :: tol = 1.0e-10_dp          !! KKT tolerance of every solve
  integer, parameter :: max_levels = 12
  integer, parameter :: max_level_schur = 11       !! cold 'schur' up to this level

contains

  !> The grid sequence to lmax with exports, then the cold solves (module header).
  subroutine bench_peers(lmax_in, scene_name)
    integer, intent(in) :: lmax_in
    character(len=*), intent(in) :: scene_name
    type(scene_t) :: scene
    type(analysis_problem_t) :: pb
    type(analysis_settings_t) :: set
    type(analysis_t) :: an
    type(level_result_t) :: res
    type(primal_system_t) :: sys
    type(status_t) :: st
    type(mg_settings_t) :: mset
    type(mg_result_t) :: mres
    real(dp), allocatable :: x(:)
    real(dp) :: total, t0, t_cold
    integer :: level, lmax, csv, ios
    character(len=256) :: path
    lmax = min(max(lmax_in, 2), max_levels)
    call scene_lookup(scene_name, scene, st)
    if (.not. is_ok(st)) then
      write (*, '(a)') 'dualsig_bench peers: ' // trim(st%msg)
      return
    end if
    call execute_command_line('mkdir -p out/peers', exitstat=ios)
    call mesh_rectangle(pb%mesh, 0.0_dp, 1.0_dp, 0.0_dp, 1.0_dp, 2, 2, 'right', st)
    call analysis_problem_set_scene(pb, scene, exact=.false.)
    open (newunit=csv, file='out/peers/' // scene_name // '_dualsig.csv', status='replace', iostat=ios)
    if (ios /= 0) then
      write (*, '(a)') 'dualsig_bench peers: cannot write out/peers/' // scene_name // '_dualsig.csv'
      return
    end if
    write (csv, '(a)') 'scene,pass,level,n,seconds,cumulative_s,iterations,kkt_residual,peak_mb'
    set%levels = lmax
    set%keep_hierarchy = .true.      ! the QP exports and the cold solve use an%mg after the last level
    set%method = 'multigrid'
    set%tol = tol
    set%dual = .false.
    write (*, '(/,a)') 'dualsig_bench: peers, ' // scene_name // ': grid sequence with multigrid, KKT 1e-10' // &
      ' (QPs exported to out/peers/, untimed)'
    write (*, '(a)') '  lvl          N   seconds  sum(s)  V-cycles  kkt_residual   peak MB'
    call analysis_start(an, pb, set, st)
    total = 0.0_dp
    do level = 1, lmax
      if (is_ok(st)) call analysis_next_level(an, res, st)
      if (.not. is_ok(st)) then
        write (*, '(a,i0,a)') 'dualsig_bench peers: level ', level, ': ' // trim(st%msg)
        exit
      end if
      total = total + res%primal_seconds
      write (*, '(i5,i11,2f9.3,i10,es14.3,f10.0)') level, res%nnode, res%primal_seconds, total, res%primal_iters, &
        res%kkt_residual, peak_memory_mb()
      write (csv, '(a,",sequence,",i0,",",i0,2(",",es12.4),",",i0,",",es12.4,",",f10.1)') scene_name, level, res%nnode, &
        res%primal_seconds, total, res%primal_iters, res%kkt_residual, peak_memory_mb()
      call primal_assemble(an%mesh, scene%problem, scene%f, tri_rule(5), sys, st=st)
      if (is_ok(st)) call primal_constraints(an%mesh, scene%problem, scene%gamma_u_markers, scene%gamma_a_markers, &
                                             sys%kind, sys%bnd, st)
      write (path, '(a,i0,a)') 'out/peers/' // scene_name // '_l', level, '.bin'
      if (level == 1) then
        call write_qp_binary(trim(path), sys, an%u, reshape([integer ::], [2, 0]), ios)
      else
        call write_qp_binary(trim(path), sys, an%u, an%mg%transfer(level)%ends, ios)
      end if
      if (ios /= 0) write (*, '(a)') 'dualsig_bench peers: cannot write ' // trim(path)
      flush (6)
    end do
    if (.not. is_ok(st) .or. level <= lmax) then
      close (csv)
      call analysis_free(an)
      return
    end if
    ! cold multigrid: the finest QP from zero on the same hierarchy
    mset%tol = tol
    allocate (x(an%mesh%nnode), source=0.0_dp)
    t0 = wall_seconds()
    call multigrid_solve(an%mg, sys%a, sys%load, sys%kind, sys%bnd, x, mset, mres, st)
    t_cold = wall_seconds() - t0
    write (*, '(a,i0,a,f9.3,a,i0,a,es10.3)') '  cold multigrid (x = 0, same hierarchy), level ', lmax, ': ', t_cold, &
      ' s, ', mres%iterations, ' V-cycles, kkt ', mres%kkt_residual
    write (csv, '(a,",cold_multigrid,",i0,",",i0,2(",",es12.4),",",i0,",",es12.4,",",f10.1)') scene_name, lmax, &
      an%mesh%nnode, t_cold, t_cold, mres%iterations, mres%kkt_residual, peak_memory_mb()
    deallocate (x)
    call cold_one_level(pb, an, lmax, scene_name, csv, 'auto')
    if (lmax <= max_level_schur) then
      call cold_one_level(pb, an, lmax, scene_name, csv, 'schur')
    else
      write (*, '(a,i0,a)') '  cold schur skipped above level ', max_level_schur, ' (one CHOLMOD factor does not fit)'
    end if
    close (csv)
    call analysis_free(an)
    write (*, '(a)') 'dualsig_bench: table written to out/peers/' // scene_name // '_dualsig.csv'
  end subroutine bench_peers

  !> A cold solve (zero start) with `method` ('schur' or 'auto': multigrid on the algebraic
  !> hierarchy) of the finest mesh of `an` given as one level, to csv as cold_schur or
  !> cold_amg.
  subroutine cold_one_level(pb, an, lmax, scene_name, csv, method)
    type(analysis_problem_t), intent(in) :: pb
    type(analysis_t), intent(in) :: an
    integer, intent(in) :: lmax, csv
    character(len=*), intent(in) :: scene_name, method
    type(analysis_problem_t) :: pc
    type(analysis_settings_t) :: set
    type(analysis_t) :: an_cold
    type(level_result_t) :: rc
    type(status_t) :: st
    character(len=:), allocatable :: label, steps
    label = merge('schur', 'amg  ', method == 'schur')
    steps = merge('pivoting steps', 'V-cycles      ', method == 'schur')
    pc = pb
    pc%mesh = an%mesh
    set%levels = 1
    set%method = method
    set%tol = tol
    set%max_iter = 100
    set%ordering = ORDERING_GEOMETRIC
    set%dual = .false.
    call analysis_start(an_cold, pc, set, st)
    if (is_ok(st)) call analysis_next_level(an_cold, rc, st)
    if (.not. is_ok(st)) then
      write (*, '(a)') '  cold ' // trim(label) // ': ' // trim(st%msg)
      return
    end if
    write (*, '(a,i0,a,f9.3,a,i0,a,es10.3)') '  cold ' // trim(rc%primal_method) // ' (x = 0, the mesh as one level), level ', &
      lmax, ': ', rc%primal_seconds, ' s, ', rc%primal_iters, ' ' // trim(steps) // ', kkt ', rc%kkt_residual
    write (csv, '(a,",cold_",a,",",i0,",",i0,2(",",es12.4),",",i0,",",es12.4,",",f10.1)') scene_name, trim(label), lmax, &
      rc%nnode, rc%primal_seconds, rc%primal_seconds, rc%primal_iters, rc%kkt_residual, peak_memory_mb()
    call analysis_free(an_cold)
  end subroutine cold_one_level

  !> The QP of sys with the solution x and the prolongation ends, in the binary format of
  !> the module header; ios /= 0 when the file cannot be written.
  subroutine write_qp_binary(path, sys, x, ends, ios)
    character(len=*), intent(in) :: path
    type(primal_system_t), intent(in) :: sys
    real(dp), intent(in) :: x(:)
    integer, intent(in) :: ends(:,:)
    integer, intent(out) :: ios
    integer :: u
    open (newunit=u, file=path, access='stream', form='unformatted', status='replace', iostat=ios)
    if (ios /= 0) return
    write (u, iostat=ios) 'DSQP0001', sys%a%n, sys%a%rowptr(sys%a%n + 1) - 1, size(ends, 2)
    if (ios == 0) write (u, iostat=ios) sys%a%rowptr, sys%a%col(1:sys%a%rowptr(sys%a%n + 1) - 1), &
      sys%a%val(1:sys%a%rowptr(sys%a%n + 1) - 1)
    if (ios == 0) write (u, iostat=ios) sys%load, sys%bnd, x, sys%kind, ends
    close (u)
  end subroutine write_qp_binary
end module dualsig_bench_peers
