!> The cost of the stream-function route to an O(N) P2 dual (doc/performance.md, "The duals
!> against the primal solve of the same mesh"): the linear solve of the P2 Laplacian (the
!> system of the stream function psi, whose curl is the divergence-free part of the BDM1
!> dual field), Dirichlet conditions and load 1 on the unit square, by dualsig's multigrid on
!> the geometric hierarchy of the primal (levels 1..L of the uniform refinements) plus one
!> more grid, P1 -> P2 of the finest mesh: the P2 nodes are the vertices and edge midpoints,
!> numbered as a red refinement numbers them, and the P1 -> P2 embedding is the same linear
!> interpolation, so mg_add_level builds it.  Against the linear P1 solve of the same mesh
!> with the same solver, to the relative residuals 1e-10 and 1e-4, twice each.
!>
!> Usage: dualsig_p2_stream_bench L   (make bench-p2-stream, L = 9)
program dualsig_p2_stream_bench
  use dualsig_kinds, only: dp
  use dualsig_status, only: status_t
  use dualsig_mesh, only: mesh_t
  use dualsig_mesh_generate, only: mesh_rectangle
  use dualsig_mesh_refine, only: mesh_refine_uniform
  use dualsig_sparse, only: csr_t, csr_pattern_from_cliques, csr_add_block
  use dualsig_qp_types, only: BOUND_FREE, BOUND_FIXED
  use dualsig_solver_multigrid, only: mg_hierarchy_t, mg_settings_t, mg_result_t, multigrid_solve, mg_clear, &
                                      mg_reset, mg_add_level
  use dualsig_clock, only: wall_seconds
  implicit none
  type(mesh_t) :: mesh, finer
  type(csr_t) :: a2, a1
  type(status_t) :: st
  type(mg_hierarchy_t) :: h1, h2
  integer, allocatable :: kind2(:), kind1(:)
  real(dp), allocatable :: f2(:), f1(:), bnd2(:), bnd1(:)
  real(dp) :: tols(2)
  integer :: lvl, l, rep, lk, ios
  character(len=16) :: arg
  lvl = 9
  ios = 0
  call get_command_argument(1, arg)
  if (len_trim(arg) > 0) read (arg, *, iostat=ios) lvl
  if (ios /= 0 .or. lvl < 2 .or. lvl > 11) then
    write (*, '(a)') 'dualsig_p2_stream_bench: expected a level from 2 to 11, got ' // trim(arg)
    error stop 2
  end if
  call mesh_rectangle(mesh, 0.0_dp, 1.0_dp, 0.0_dp, 1.0_dp, 2, 2, 'right', st)
  call mg_reset(h1, mesh%nnode)
  call mg_reset(h2, mesh%nnode)
  do l = 2, lvl
    call mg_add_level(h1, mesh%nnode, mesh%edge_nodes, st)
    if (st%code == 0) call mg_add_level(h2, mesh%nnode, mesh%edge_nodes, st)
    if (st%code == 0) call mesh_refine_uniform(mesh, finer, st)
    if (st%code /= 0) exit
    mesh = finer
  end do
  if (st%code == 0) call mg_add_level(h2, mesh%nnode, mesh%edge_nodes, st)   ! P1 -> P2 of the finest mesh
  if (st%code /= 0) then
    write (*, '(a)') 'dualsig_p2_stream_bench: ' // trim(st%msg)
    error stop 1
  end if
  write (*, '(a,i0,a,i0,a,i0,a)') 'dualsig_p2_stream_bench: level ', lvl, ', ', mesh%nnode, ' P1 unknowns, ', &
    mesh%nnode + mesh%nedge, ' P2 unknowns (command: bin/dualsig_p2_stream_bench ' // trim(arg) // ')'
  call assemble(mesh, .true., a2, f2, kind2, bnd2)
  call assemble(mesh, .false., a1, f1, kind1, bnd1)
  tols = [1.0e-10_dp, 1.0e-4_dp]
  do rep = 1, 2
    do lk = 1, 2
      call timed_solve('P1', h1, a1, f1, kind1, bnd1, tols(lk))
      call timed_solve('P2', h2, a2, f2, kind2, bnd2, tols(lk))
    end do
  end do
  call mg_clear(h1)
  call mg_clear(h2)
contains
  !> A linear solve from zero to the relative residual tol on the hierarchy h, timed.
  subroutine timed_solve(label, h, a, f, kind, bnd, tol)
    character(len=*), intent(in) :: label
    type(mg_hierarchy_t), intent(inout) :: h
    type(csr_t), intent(in) :: a
    real(dp), intent(in) :: f(:), bnd(:), tol
    integer, intent(in) :: kind(:)
    type(mg_settings_t) :: ms
    type(mg_result_t) :: mr
    type(status_t) :: st
    real(dp), allocatable :: x(:)
    real(dp) :: t0
    ms%tol = tol
    allocate (x(a%n), source=0.0_dp)
    t0 = wall_seconds()
    call multigrid_solve(h, a, f, kind, bnd, x, ms, mr, st)
    write (*, '(a,es8.1,a,i4,a,f8.3,a,i0)') '  ' // label // ' linear, geometric  tol', tol, ' V-cycles', &
      mr%iterations, ' s', wall_seconds() - t0, ' status ', st%code
  end subroutine timed_solve

  !> The P1 or P2 stiffness matrix of the mesh (edge-midpoint rule: exact for the quadratic
  !> integrands), the load vector of f = 1 and u = 0 on the boundary of the unit square.
  subroutine assemble(mesh, p2, a, f, kind, bnd)
    type(mesh_t), intent(in) :: mesh
    logical, intent(in) :: p2
    type(csr_t), intent(out) :: a
    real(dp), allocatable, intent(out) :: f(:), bnd(:)
    integer, allocatable, intent(out) :: kind(:)
    real(dp) :: g(2,3), area, k(6,6), gr(2,6,3), lam(3,3)
    integer :: t, q, i, j, n, nd, e
    ! P2 basis (barycentric lambda): vertex i lambda_i (2 lambda_i - 1), edge i (vertices i,
    ! i+1) 4 lambda_i lambda_(i+1); quadrature points: the edge midpoints, weights area/3
    real(dp), allocatable :: xy(:,:)
    integer, allocatable :: cl(:,:)
    nd = merge(6, 3, p2)
    n = mesh%nnode
    if (p2) n = n + mesh%nedge
    allocate (cl(nd, mesh%ntri), xy(2, n), f(n), bnd(n), kind(n))
    xy(:, 1:mesh%nnode) = mesh%xy
    if (p2) then
      do e = 1, mesh%nedge
        xy(:, mesh%nnode + e) = 0.5_dp * (mesh%xy(:, mesh%edge_nodes(1, e)) + mesh%xy(:, mesh%edge_nodes(2, e)))
      end do
    end if
    do t = 1, mesh%ntri
      cl(1:3, t) = mesh%tri(:, t)
      if (p2) cl(4:6, t) = mesh%nnode + mesh%tri_edge(:, t)
    end do
    call csr_pattern_from_cliques(n, cl, a, st)
    if (st%code /= 0) then
      write (*, '(a)') 'dualsig_p2_stream_bench: ' // trim(st%msg)
      error stop 1
    end if
    a%val = 0.0_dp
    f = 0.0_dp
    lam = reshape([0.5_dp, 0.5_dp, 0.0_dp, 0.0_dp, 0.5_dp, 0.5_dp, 0.5_dp, 0.0_dp, 0.5_dp], [3, 3])
    do t = 1, mesh%ntri
      associate (p1 => mesh%xy(:, mesh%tri(1, t)), p2_ => mesh%xy(:, mesh%tri(2, t)), p3 => mesh%xy(:, mesh%tri(3, t)))
        area = 0.5_dp * ((p2_(1) - p1(1)) * (p3(2) - p1(2)) - (p3(1) - p1(1)) * (p2_(2) - p1(2)))
        g(:, 1) = [p2_(2) - p3(2), p3(1) - p2_(1)] / (2 * area)
        g(:, 2) = [p3(2) - p1(2), p1(1) - p3(1)] / (2 * area)
        g(:, 3) = [p1(2) - p2_(2), p2_(1) - p1(1)] / (2 * area)
      end associate
      do q = 1, 3
        do i = 1, 3
          if (p2) then
            gr(:, i, q) = (4 * lam(i, q) - 1) * g(:, i)
            j = mod(i, 3) + 1
            gr(:, 3 + i, q) = 4 * (lam(j, q) * g(:, i) + lam(i, q) * g(:, j))
          else
            gr(:, i, q) = g(:, i)
          end if
        end do
      end do
      k = 0.0_dp
      do q = 1, 3
        do i = 1, nd
          do j = 1, nd
            k(i, j) = k(i, j) + area / 3 * dot_product(gr(:, i, q), gr(:, j, q))
          end do
        end do
      end do
      call csr_add_block(a, cl(:, t), k(1:nd, 1:nd))
      if (p2) then
        f(cl(4:6, t)) = f(cl(4:6, t)) + area / 3
      else
        f(cl(1:3, t)) = f(cl(1:3, t)) + area / 3
      end if
    end do
    kind = BOUND_FREE
    bnd = 0.0_dp
    do i = 1, n
      if (abs(xy(1, i)) < 1e-14 .or. abs(xy(2, i)) < 1e-14 .or. abs(xy(1, i) - 1) < 1e-14 .or. &
          abs(xy(2, i) - 1) < 1e-14) kind(i) = BOUND_FIXED
    end do
  end subroutine assemble
end program dualsig_p2_stream_bench
