!> The dual problem of P2 by equilibrium elements (Sections 4-6).
!>
!> lambda^h = lambda^f + q^h, where lambda^f = lambda_bar + curl(omega) is the particular
!> field of dualsig_particular_field (div lambda^f = -f, lambda^f . nu = -g_h exactly on
!> every Gamma_a edge) and q^h minimises J(q) = 1/2 ||q||^2 + (lambda^f, q) over the
!> equilibrium elements with q.nu >= g_h on Gamma_a (4.5).  Then lambda^h . nu = q.nu - g_h
!> >= 0 on Gamma_a and div lambda^h = -f: lambda^h is admissible (in U_2) and the bound
!> (6.26) is guaranteed.  The solver's field has a small divergence defect (rounding, or an
!> unfinished Uzawa iteration); dualsig_equilibrium_correction removes it exactly by
!> constant fluxes on Gamma_u and interior edges, so the returned field is admissible to
!> rounding whichever solver ran (res%defect_solver before, res%defect after).
!>
!> Solvers:
!> - 'augmented' (the fast variant): continuity eliminated by global edge-end fluxes (BDM1),
!>   the divergence rows by an augmented Lagrangian whose matrix A + r D^T D is factorised
!>   once by CHOLMOD, the Gamma_a rows are simple bounds handled inside each outer step by
!>   the inner solver: 'schur' (their dense Schur complement, exact QP on it) or
!>   'active_set' (dualsig_solver_augmented);
!> - 'multigrid': the divergence-free part as the curl of a continuous P2 stream function,
!>   the Gamma_a rows by a primal-dual active set, each step one linear multigrid solve
!>   (dualsig_dual_p2_stream): O(N) time and memory, no factorisation; simply connected
!>   domains and the polynomial lambda^f;
!> - 'uzawa': the paper's Uzawa on (4.8) in the element parameters, with free multipliers
!>   for D (divergence and continuity rows) and non-negative ones for E (Gamma_a), each
!>   iteration an element-local solve with the factored A_e (LAPACK).  Its iterate is made
!>   continuous (the two sides of an edge averaged), clipped to the Gamma_a bounds and
!>   equilibrated as above.
module dualsig_problem_dual_p2
  use dualsig_kinds, only: dp, i8
  use dualsig_clock, only: wall_seconds
  use dualsig_fields, only: field_t
  use dualsig_mesh, only: mesh_t
  use dualsig_sparse, only: csr_t, rect_t, rect_matvec
  use dualsig_quadrature, only: tri_rule_t, tri_rule, tri_points_t, tri_points_set
  use dualsig_sparse_direct, only: ORDERING_AMD, ORDERING_GEOMETRIC
  use dualsig_ordering_geometric, only: geometric_ordering
  use dualsig_spd_solver, only: block_diag_spd_t
  use dualsig_qp_types, only: BOUND_FREE, BOUND_LOWER
  use dualsig_solver_uzawa, only: uzawa_settings_t, uzawa_result_t, uzawa_solve
  use dualsig_solver_augmented, only: augmented_settings_t, augmented_result_t, augmented_solve
  use dualsig_elements_equilibrium, only: equilibrium_element_load, equilibrium_c_of
  use dualsig_elements_p1, only: p1_element_mass
  use dualsig_assembly_equilibrium, only: equilibrium_map_t, equilibrium_map, equilibrium_elements, equilibrium_div_coefficients, &
                                          assemble_equilibrium_global, equilibrium_to_global, &
                                          equilibrium_to_local, equilibrium_div_rows_global, &
                                          equilibrium_rows_local, equilibrium_gamma_a_dofs
  use dualsig_particular_field, only: particular_field_t, particular_field_build, lambda_f_at
  use dualsig_equilibrium_correction, only: equilibrate_divergence
  use dualsig_load_data, only: load_data_t, load_data_build
  use dualsig_dual_p2_field, only: dual_p2_field_t, dual_p2_lambda, bubble_coefficients, bubble_load_moments
  use dualsig_status, only: status_t, set_error, is_ok, DS_ERR_INPUT
  use dualsig_solver_multigrid, only: mg_hierarchy_t
  use dualsig_dual_p2_stream, only: stream_settings_t, stream_result_t, stream_dual_solve
  use dualsig_strings, only: itoa
  use dualsig_alloc, only: alloc_failed, BYTES_REAL
  implicit none
  private

  ! dual_p2_field_t and dual_p2_lambda live in dualsig_dual_p2_field (fem); re-exported
  public :: dual_p2_settings_t, dual_p2_result_t, dual_p2_field_t, dual_p2_solve, dual_p2_lambda, edge_end_ordering, &
            dual_p2_check_assumptions

  !> Degree of the quadrature for the element loads b_e.  lambda^f is not a polynomial;
  !> the loads only affect how close q^h is to the exact discrete minimiser, never the
  !> admissibility of lambda^h (any q^h of K_h gives an admissible lambda^h).
  integer, parameter :: load_degree = 5

  type :: dual_p2_settings_t
    character(len=16) :: method = 'augmented'  !! 'augmented' or 'uzawa'
    real(dp) :: rho = 0.0_dp                   !! Uzawa step, 0 = automatic
    real(dp) :: tol = 1.0e-10_dp               !! Uzawa tolerance
    integer :: max_iter = 20000                !! Uzawa iterations
    real(dp) :: penalty = 0.0_dp               !! augmented Lagrangian r, 0 = automatic
    real(dp) :: defect_tol = 1.0e-13_dp        !! augmented: relative divergence defect
    integer :: ordering = ORDERING_AMD          !! CHOLMOD ordering (AMD: cheapest analysis, see doc/performance.md)
    character(len=16) :: inner = 'schur'        !! augmented: inner solver, 'schur' or 'active_set'
    !> lambda^f: 'polynomial' (piecewise linear, div = -f_T: every bound integral exact, f - f_T
    !> an oscillation term) or 'stream' (the paper's lambda_bar + curl omega, div = -f)
    character(len=16) :: particular = 'polynomial'
    !> multigrid: > 0 stops the stream function's solves when the part of est they could still
    !> remove is predicted below this (est's units; the adaptive loop's algebraic share)
    real(dp) :: est_tol = 0.0_dp
    !> multigrid, with est_tol and a start psi (the last level of a uniform run): at most this
    !> many Gauss-Seidel sweeps before any multigrid (dualsig_dual_p2_stream, smooth_first)
    integer :: smooth_sweeps = 0
  end type dual_p2_settings_t

  type :: dual_p2_result_t
    integer :: iterations = 0          !! Uzawa iterations, or outer augmented-Lagrangian steps
    integer :: factorisations = 0      !! augmented: CHOLMOD (re)factorisations
    character(len=16) :: inner = ''    !! augmented: the inner solver used ('schur' or 'active_set')
    integer :: inner_iterations = 0    !! augmented: dense pivoting ('schur') or active-set iterations in all
    integer :: sweeps = 0              !! multigrid: Gauss-Seidel sweeps before the V-cycles (smooth_sweeps)
    real(dp) :: residual = 0.0_dp      !! Uzawa residual
    real(dp) :: defect = 0.0_dp        !! relative divergence defect of the returned field
    real(dp) :: defect_solver = 0.0_dp !! the same of the solver's field, before equilibrate_divergence
    logical :: converged = .false.
    real(dp) :: rho = 0.0_dp
    real(dp) :: lambda_max = 0.0_dp
    real(dp) :: penalty = 0.0_dp
    integer(i8) :: nnz_factor = 0
    character(len=8) :: ordering = ''
    integer :: nconstraints = 0
    integer :: nactive = 0
    ! wall-clock profile of the solve (seconds)
    real(dp) :: seconds_particular = 0.0_dp  !! particular field lambda^f (g_h, stream function on Gamma_a)
    real(dp) :: seconds_elements = 0.0_dp    !! C_e, A_e, divergence rows
    real(dp) :: seconds_loads = 0.0_dp       !! element loads b_e (lambda^f at the quadrature points)
    real(dp) :: seconds_solver = 0.0_dp      !! global assembly and the solver (factorisations included)
    logical :: particular_converged = .true. !! 'stream': every line integral of lambda_bar converged
    !> multigrid with est_tol: the part of est the solve left, as predicted (0: solved to its
    !> residual tolerance)
    real(dp) :: est_gap = 0.0_dp
  end type dual_p2_result_t

contains

  !> The paper's assumptions: (A2) every boundary loop contains an edge of Gamma_u.
  !> (A3), the end points of Gamma_a are mesh vertices, holds by construction: Gamma_a is a
  !> union of marked boundary edges.
  subroutine dual_p2_check_assumptions(mesh, is_gamma_a, st)
    type(mesh_t), intent(in) :: mesh
    logical, intent(in) :: is_gamma_a(:)
    type(status_t), intent(out) :: st
    integer :: l
    do l = 1, mesh%nloop
      if (all(is_gamma_a(mesh%loop_bedge(mesh%loop_start(l):mesh%loop_start(l + 1) - 1)))) then
        call set_error(st, DS_ERR_INPUT, 'dual P2: boundary loop ' // itoa(l) // &
          ' has no Gamma_u edge; the equilibrium dual needs (A2): every boundary loop meets Gamma_u')
        return
      end if
    end do
  end subroutine dual_p2_check_assumptions

  !> Solve (4.5) on `mesh`; is_gamma_a(nbedge) marks the Signorini edges, x_start is the
  !> abscissa where lambda_bar's integration starts (f must be defined on the mesh's
  !> bounding box).
  !> u_primal (optional, nnode): the primal solution on the same mesh; by complementarity
  !> (lambda . nu u = 0 on Gamma_a) the dual constraint is predicted active where u > 0,
  !> which starts the active-set method near its solution.
  subroutine dual_p2_solve(mesh, f, is_gamma_a, x_start, settings, field, res, st, breaks, u_primal, load, mg, psi, &
                           active_set, flux_f)
    type(mesh_t), intent(in) :: mesh
    class(field_t), intent(in) :: f
    logical, intent(in) :: is_gamma_a(:)
    real(dp), intent(in) :: x_start
    type(dual_p2_settings_t), intent(in) :: settings
    type(dual_p2_field_t), intent(out) :: field
    type(dual_p2_result_t), intent(out) :: res
    type(status_t), intent(out) :: st
    real(dp), intent(in), optional :: breaks(:)   !! abscissae of kinks of f (see particular field)
    real(dp), intent(in), optional :: u_primal(:)
    type(load_data_t), intent(in), optional :: load   !! polynomial lambda^f: the load data (built when absent)
    type(mg_hierarchy_t), intent(in), optional :: mg  !! 'multigrid': the primal's geometric hierarchy, if any
    !> 'multigrid': the stream function; on entry its start when of this mesh's size (the
    !> previous level's, prolongated), on return the solution
    real(dp), allocatable, intent(inout), optional :: psi(:)
    !> 'multigrid': the active set on Gamma_a, on entry the start (the previous level's,
    !> stream_prolongate_set), on return the final one
    integer, allocatable, intent(inout), optional :: active_set(:,:)
    !> polynomial lambda^f: on entry, when of this mesh's size (2 nedge), the start of its
    !> fluxes (the last level's lambda^f, equilibrium_prolongate_bisection), which
    !> keeps lambda^f and with it the carried psi close to the last step's; on return this
    !> level's lambda^f fluxes (particular_polynomial)
    real(dp), allocatable, intent(inout), optional :: flux_f(:)
    type(equilibrium_map_t) :: map
    real(dp), allocatable :: ae(:,:,:), c(:,:,:), d(:,:), be(:,:), bx(:), x(:), bnd(:), y(:), z(:), e(:), gh(:,:)
    logical, allocatable :: on_gamma_a(:)
    integer, allocatable :: kind(:), row_kind(:)
    type(csr_t) :: a
    type(rect_t) :: dmat, bmat
    type(augmented_settings_t) :: aug
    type(augmented_result_t) :: ares
    type(block_diag_spd_t) :: blocks
    type(uzawa_settings_t) :: uset
    type(uzawa_result_t) :: ures
    type(status_t) :: st_eq
    real(dp) :: t0
    integer :: ist

    call dual_p2_check_assumptions(mesh, is_gamma_a, st)
    if (st%code /= 0) return
    t0 = wall_seconds()
    if (trim(settings%method) == 'multigrid') then     ! the stream function needs neither C_e nor A_e
      call equilibrium_div_coefficients(mesh, d, st)
    else
      call equilibrium_elements(mesh, c, ae, d, st)
      if (allocated(c)) deallocate (c)                 ! computed where the field is evaluated
    end if
    if (st%code /= 0) return
    call equilibrium_map(mesh, map, st)
    if (.not. is_ok(st)) return
    res%seconds_elements = lap(t0)
    select case (trim(settings%particular))
    case ('polynomial')
      if (trim(settings%method) == 'multigrid') then   ! the loads summed at once (stream_method)
        call particular_polynomial(mesh, f, map, d, is_gamma_a, field, st=st, breaks=breaks, load=load, &
                                   flux_f=flux_f, bx=bx)
      else
        call particular_polynomial(mesh, f, map, d, is_gamma_a, field, be, st, breaks, load, flux_f)
      end if
      if (.not. is_ok(st)) return
      res%seconds_particular = lap(t0)
      allocate (gh(2, mesh%nbedge), stat=ist)
      if (alloc_failed(ist, st, 'the flux bounds on Gamma_a', 2 * mesh%nbedge, BYTES_REAL)) return
      gh = 0.0_dp                                        ! lambda^f . nu = 0 on Gamma_a
    case ('stream')
      call particular_field_build(mesh, f, x_start, is_gamma_a, field%pf, st, breaks)
      if (.not. is_ok(st)) return
      res%particular_converged = field%pf%converged
      res%seconds_particular = lap(t0)
      call stream_loads(mesh, f, field, be, st)
      if (.not. is_ok(st)) return
      gh = field%pf%gh
    case default
      call set_error(st, DS_ERR_INPUT, "dual P2: unknown particular field '" // trim(settings%particular) // &
        "'; expected 'polynomial' or 'stream'")
      return
    end select
    res%seconds_loads = lap(t0)
    allocate (x(2 * mesh%nedge), stat=ist)
    if (alloc_failed(ist, st, 'the equilibrium fluxes', 2 * mesh%nedge, BYTES_REAL)) return
    if (trim(settings%method) /= 'multigrid') then   ! 'multigrid': after the solve (stream_method)
      call equilibrium_gamma_a_dofs(mesh, is_gamma_a, gh, on_gamma_a, bnd, st)
      if (.not. is_ok(st)) return
      res%nconstraints = mesh%ntri + count(on_gamma_a)
    end if

    select case (trim(settings%method))
    case ('augmented')
      call assemble_equilibrium_global(map, ae, a, st)
      if (.not. is_ok(st)) return
      allocate (bx(2 * mesh%nedge), kind(2 * mesh%nedge), stat=ist)
      if (alloc_failed(ist, st, 'the equilibrium load', 4 * mesh%nedge, BYTES_REAL)) return
      call equilibrium_to_global(map, be, bx)
      call equilibrium_div_rows_global(map, d, dmat, st)
      if (.not. is_ok(st)) return
      kind = BOUND_FREE
      where (on_gamma_a) kind = BOUND_LOWER
      x = 0.0_dp
      if (present(u_primal)) call start_from_primal(mesh, u_primal, is_gamma_a, bnd, x)
      aug%r = settings%penalty
      aug%tol = settings%defect_tol
      aug%ordering = settings%ordering
      aug%inner = settings%inner
      if (settings%ordering == ORDERING_GEOMETRIC) then
        call edge_end_ordering(mesh, a, aug%ordering, aug%perm, st)
        if (st%code /= 0) return
      end if
      call augmented_solve(a, bx, dmat, kind, bnd, x, aug, ares, st)
      if (.not. is_ok(st)) return
      res%iterations = ares%outer
      res%factorisations = ares%factorisations
      res%inner = ares%inner
      res%inner_iterations = ares%inner_iterations
      res%converged = ares%converged
      res%penalty = ares%r
      res%nnz_factor = ares%nnz_factor
      res%ordering = ares%ordering
      res%nactive = ares%nactive
      res%residual = ares%kkt_residual
    case ('multigrid')
      call stream_method(mesh, map, d, bx, is_gamma_a, settings, x, res, st, u_primal, mg, psi, active_set)
      if (.not. is_ok(st)) return
      call equilibrium_gamma_a_dofs(mesh, is_gamma_a, gh, on_gamma_a, bnd, st_eq)   ! (st: the solve's warning)
      if (.not. is_ok(st_eq)) then
        st = st_eq
        return
      end if
      res%nconstraints = mesh%ntri + count(on_gamma_a)
      where (on_gamma_a) x = max(x, bnd)
    case ('uzawa')
      call blocks%factor(ae, st)
      if (st%code /= 0) return
      call equilibrium_rows_local(mesh, map, d, on_gamma_a, bnd, bmat, row_kind, e, st)
      if (.not. is_ok(st)) return
      allocate (y(6 * mesh%ntri), z(bmat%m), stat=ist)
      if (alloc_failed(ist, st, 'the Uzawa unknowns', 6 * mesh%ntri + bmat%m, BYTES_REAL)) return
      y = 0.0_dp
      z = 0.0_dp
      uset%rho = settings%rho
      uset%tol = settings%tol
      uset%max_iter = settings%max_iter
      call uzawa_solve(blocks, reshape(be, [6 * mesh%ntri]), bmat, row_kind, e, y, z, uset, ures, st)
      if (.not. is_ok(st)) return
      res%iterations = ures%iterations
      res%residual = ures%residual
      res%converged = ures%converged
      res%rho = ures%rho
      res%lambda_max = ures%lambda_max
      res%nconstraints = bmat%m
      res%nactive = count(z(mesh%ntri + 1:) > 0.0_dp .and. row_kind(mesh%ntri + 1:) == 1)
      ! continuous fluxes: average the two parameters of each global unknown; Gamma_a bounds
      call average_to_global(map, reshape(y, [6, mesh%ntri]), x, st)
      if (.not. is_ok(st)) return
      where (on_gamma_a) x = max(x, bnd)
    case default
      call set_error(st, DS_ERR_INPUT, 'dual P2: unknown method "' // trim(settings%method) // &
        '"; expected augmented, multigrid or uzawa')
      return
    end select
    ! the solver's defect, then exact equilibration on Gamma_u and interior edges (own status:
    ! st may hold the solver's warning)
    allocate (field%beta(6, mesh%ntri), stat=ist)
    if (alloc_failed(ist, st, 'the equilibrium fluxes', 6 * mesh%ntri, BYTES_REAL)) return
    call equilibrium_to_local(map, x, field%beta)
    res%defect_solver = divergence_defect(d, field%beta)
    call equilibrate_divergence(mesh, map, d, is_gamma_a, x, st_eq)
    if (st_eq%code /= 0) then
      st = st_eq
      return
    end if
    call equilibrium_to_local(map, x, field%beta)
    res%defect = divergence_defect(d, field%beta)
    res%seconds_solver = lap(t0)
  end subroutine dual_p2_solve

  !> method 'multigrid': the dual by its stream function (dualsig_dual_p2_stream), for the
  !> polynomial lambda^f (zero flux on Gamma_a); x: the edge-end fluxes.  The per-triangle
  !> arrays the stream function does not need are not held while it runs (its solve is the
  !> peak of an adaptive step's memory): the element loads are summed into the edge loads bx
  !> as they are formed (particular_polynomial), the map and the divergence rows d are freed
  !> and rebuilt after the solve (O(ntri), a few per cent of its time).
  subroutine stream_method(mesh, map, d, bx, is_gamma_a, settings, x, res, st, u_primal, mg, psi, active_set)
    type(mesh_t), intent(in) :: mesh
    type(equilibrium_map_t), intent(inout) :: map
    real(dp), allocatable, intent(inout) :: d(:,:)
    real(dp), allocatable, intent(inout) :: bx(:)   !! the edge loads (particular_polynomial); freed
    logical, intent(in) :: is_gamma_a(:)
    type(dual_p2_settings_t), intent(in) :: settings
    real(dp), intent(out) :: x(:)
    type(dual_p2_result_t), intent(inout) :: res
    type(status_t), intent(inout) :: st
    real(dp), intent(in), optional :: u_primal(:)
    type(mg_hierarchy_t), intent(in), optional :: mg
    real(dp), allocatable, intent(inout), optional :: psi(:)
    integer, allocatable, intent(inout), optional :: active_set(:,:)
    type(stream_settings_t) :: sset
    type(stream_result_t) :: sres
    type(status_t) :: st_rebuild
    if (trim(settings%particular) /= 'polynomial') then
      call set_error(st, DS_ERR_INPUT, 'dual P2: method multigrid needs &dual particular = ''polynomial'' (a ' // &
        'particular field without flux on Gamma_a), not ''' // trim(settings%particular) // '''')
      return
    end if
    deallocate (d, map%dof, map%sgn)
    sset%est_tol = settings%est_tol
    sset%smooth_sweeps = settings%smooth_sweeps
    call stream_dual_solve(mesh, bx, is_gamma_a, x, sset, sres, st, mg, u_primal, psi, active_set)
    if (.not. is_ok(st)) return
    deallocate (bx)
    call equilibrium_map(mesh, map, st_rebuild)      ! (st keeps the solve's warning, if any)
    if (is_ok(st_rebuild)) call equilibrium_div_coefficients(mesh, d, st_rebuild)
    if (.not. is_ok(st_rebuild)) then
      st = st_rebuild
      return
    end if
    res%est_gap = sres%est_gap
    res%iterations = sres%steps
    res%inner = 'multigrid'
    if (.not. sres%geometric) res%inner = trim(merge('multigrid_p1amg', 'multigrid_amg  ', sres%p1_coarse))
    if (.not. sres%hierarchy) res%inner = 'gauss_seidel'
    res%sweeps = sres%sweeps
    res%inner_iterations = sres%vcycles
    res%converged = sres%converged
    res%nactive = sres%nactive
    res%ordering = 'none'
  end subroutine stream_method

  !> The polynomial particular field (dualsig_dual_p2_field): flux parameters beta_f of a
  !> piecewise linear field with outward flux -f_T |T| through the boundary of every
  !> triangle (div = -f_T, f_T the mean of f from the load data) and zero flux on Gamma_a,
  !> by constant normal fluxes on a spanning forest of the dual graph rooted at Gamma_u
  !> (dualsig_equilibrium_correction: O(ntri), exact to rounding), plus the bubbles with
  !> div = -g_T . (x - x_T); and the element loads b_e = -A_e beta_f - C_e^T int sigma . Phi
  !> of (4.7), exact ((lambda^f, q) = beta_f^T A_e beta for fields of the same element; the
  !> bubble part is a cubic, its moments in closed form, bubble_load_moments).
  !> flux_f (optional): on entry, when of size 2 nedge, the fluxes the equilibration starts
  !> from instead of zero (any start gives an admissible lambda^f; a start close to the last
  !> level's lambda^f keeps the new one close to it); on return the fluxes of this
  !> lambda^f.  The loads: per triangle in be(6, ntri), or (bx) summed at once into the
  !> global edge-end unknowns (equilibrium_to_global), without the per-triangle array.
  subroutine particular_polynomial(mesh, f, map, d, is_gamma_a, field, be, st, breaks, load, flux_f, bx)
    type(mesh_t), intent(in) :: mesh
    class(field_t), intent(in) :: f
    type(equilibrium_map_t), intent(in) :: map
    real(dp), intent(in) :: d(:,:)
    logical, intent(in) :: is_gamma_a(:)
    type(dual_p2_field_t), intent(inout) :: field
    real(dp), allocatable, intent(out), optional :: be(:,:)
    type(status_t), intent(out) :: st
    real(dp), intent(in), optional :: breaks(:)
    type(load_data_t), intent(in), optional :: load
    real(dp), allocatable, intent(inout), optional :: flux_f(:)
    real(dp), allocatable, intent(out), optional :: bx(:)
    type(load_data_t) :: own
    if (present(load)) then
      call particular_of_load(mesh, map, d, is_gamma_a, load, field, st, flux_f, be, bx)
    else
      call load_data_build(mesh, f, own, st, breaks)
      if (.not. is_ok(st)) return
      call particular_of_load(mesh, map, d, is_gamma_a, own, field, st, flux_f, be, bx)
    end if
  end subroutine particular_polynomial

  !> particular_polynomial with its load data.
  subroutine particular_of_load(mesh, map, d, is_gamma_a, load, field, st, flux_f, be, bx)
    type(mesh_t), intent(in) :: mesh
    type(equilibrium_map_t), intent(in) :: map
    real(dp), intent(in) :: d(:,:)
    logical, intent(in) :: is_gamma_a(:)
    type(load_data_t), intent(in) :: load
    type(dual_p2_field_t), intent(inout) :: field
    type(status_t), intent(inout) :: st
    real(dp), allocatable, intent(inout), optional :: flux_f(:)
    real(dp), allocatable, intent(out), optional :: be(:,:)
    real(dp), allocatable, intent(out), optional :: bx(:)
    real(dp), allocatable :: xf(:)
    real(dp) :: xy(2, 3), c(6, 6), me(3, 3), w(6), v(6), bt(6)
    integer :: t, k, ist
    allocate (xf(2 * mesh%nedge), stat=ist)
    if (alloc_failed(ist, st, 'the particular fluxes', 2 * mesh%nedge, BYTES_REAL)) return
    xf = 0.0_dp
    if (present(flux_f)) then
      if (allocated(flux_f)) then
        if (size(flux_f) == size(xf)) xf = flux_f
      end if
    end if
    call equilibrate_divergence(mesh, map, d, is_gamma_a, xf, st, -load%mean * triangle_areas(mesh))
    if (.not. is_ok(st)) return
    field%polynomial = .true.
    allocate (field%beta_f(6, mesh%ntri), field%bubble(3, mesh%ntri), stat=ist)
    if (alloc_failed(ist, st, 'the particular field', 9 * mesh%ntri, BYTES_REAL)) return
    call equilibrium_to_local(map, xf, field%beta_f)
    if (present(flux_f)) call move_alloc(xf, flux_f)
    if (allocated(xf)) deallocate (xf)
    if (present(bx)) then
      allocate (bx(2 * mesh%nedge), stat=ist)
      if (alloc_failed(ist, st, 'the equilibrium load', 2 * mesh%nedge, BYTES_REAL)) return
      bx = 0.0_dp
    else if (present(be)) then
      allocate (be(6, mesh%ntri), stat=ist)
      if (alloc_failed(ist, st, 'the element loads', 6 * mesh%ntri, BYTES_REAL)) return
    end if
    do t = 1, mesh%ntri
      xy = mesh%xy(:, mesh%tri(:, t))
      field%bubble(:, t) = bubble_coefficients(xy, load%slope(:, t))
      ! b_e = -C_e^T (int sigma . Phi + kron(M_e, I_2) C_e beta_f): the bubble's moments in
      ! closed form, and A_e beta_f = C_e^T kron(M_e, I_2) C_e beta_f without forming A_e
      c = equilibrium_c_of(xy)
      call p1_element_mass(xy, me)
      w = matmul(c, field%beta_f(:, t))            ! lambda^f's linear part at the vertices
      v = bubble_load_moments(xy, field%bubble(:, t))
      do k = 1, 3
        v(2 * k - 1:2 * k) = v(2 * k - 1:2 * k) + me(k, 1) * w(1:2) + me(k, 2) * w(3:4) + me(k, 3) * w(5:6)
      end do
      bt = -matmul(transpose(c), v)
      if (present(bx)) then                        ! equilibrium_to_global, one triangle at a time
        do k = 1, 6
          bx(map%dof(k, t)) = bx(map%dof(k, t)) + map%sgn(k, t) * bt(k)
        end do
      else if (present(be)) then
        be(:, t) = bt
      end if
    end do
  end subroutine particular_of_load

  !> |T| of every triangle.
  function triangle_areas(mesh) result(a)
    type(mesh_t), intent(in) :: mesh
    real(dp) :: a(mesh%ntri)
    real(dp) :: xy(2, 3)
    integer :: t
    do t = 1, mesh%ntri
      xy = mesh%xy(:, mesh%tri(:, t))
      a(t) = 0.5_dp * abs((xy(1, 2) - xy(1, 1)) * (xy(2, 3) - xy(2, 1)) - (xy(1, 3) - xy(1, 1)) * (xy(2, 2) - xy(2, 1)))
    end do
  end function triangle_areas

  !> The element loads b_e = -C_e^T int lambda^f . Phi (4.7) of the paper's particular field
  !> (lambda^f at the points of a degree-load_degree rule, split at its breaks).
  subroutine stream_loads(mesh, f, field, be, st)
    type(mesh_t), intent(in) :: mesh
    class(field_t), intent(in) :: f
    type(dual_p2_field_t), intent(in) :: field
    real(dp), allocatable, intent(out) :: be(:,:)
    type(status_t), intent(inout) :: st
    type(tri_rule_t) :: rule
    type(tri_points_t) :: tp
    real(dp), allocatable :: lam(:,:)
    integer :: t, k, ist
    rule = tri_rule(load_degree)
    allocate (be(6, mesh%ntri), stat=ist)
    if (alloc_failed(ist, st, 'the element loads', 6 * mesh%ntri, BYTES_REAL)) return
    do t = 1, mesh%ntri
      call tri_points_set(mesh%xy(:, mesh%tri(:, t)), rule, tp, field%pf%breaks(1:field%pf%nbreaks))
      if (allocated(lam)) deallocate (lam)
      allocate (lam(2, tp%n))                      ! small: the points of one triangle
      do k = 1, tp%n
        lam(:, k) = lambda_f_at(field%pf, mesh, f, t, tp%p(1, k), tp%p(2, k))
      end do
      call equilibrium_element_load(equilibrium_c_of(mesh%xy(:, mesh%tri(:, t))), tp, lam, be(:, t))
    end do
  end subroutine stream_loads

  !> The ordering of the global edge-end fluxes chosen by geometric_ordering (nested
  !> dissection for large meshes): unknown 2 (e - 1) + j sits at the point of edge e one
  !> third of the way from its end node j.
  subroutine edge_end_ordering(mesh, a, ord, perm, st)
    type(mesh_t), intent(in) :: mesh
    type(csr_t), intent(in) :: a
    integer, intent(out) :: ord
    integer, allocatable, intent(out) :: perm(:)
    type(status_t), intent(out) :: st
    real(dp), allocatable :: xy(:,:)
    real(dp), parameter :: third = 1.0_dp / 3.0_dp
    integer :: e, n1, n2, ist
    allocate (xy(2, 2 * mesh%nedge), stat=ist)
    if (alloc_failed(ist, st, 'the points of the edge-end unknowns', 4 * mesh%nedge, BYTES_REAL)) return
    do e = 1, mesh%nedge
      n1 = mesh%edge_nodes(1, e)
      n2 = mesh%edge_nodes(2, e)
      xy(:, 2 * e - 1) = (1.0_dp - third) * mesh%xy(:, n1) + third * mesh%xy(:, n2)
      xy(:, 2 * e) = third * mesh%xy(:, n1) + (1.0_dp - third) * mesh%xy(:, n2)
    end do
    call geometric_ordering(xy, a, ord, perm, st)
  end subroutine edge_end_ordering

  !> Seconds since t0, and t0 reset to now.
  real(dp) function lap(t0)
    real(dp), intent(inout) :: t0
    real(dp) :: now
    now = wall_seconds()
    lap = now - t0
    t0 = now
  end function lap

  !> Start values of the Gamma_a unknowns from the primal solution: at its bound (predicted
  !> active: lambda . nu = 0) where u > 0, above it where u = 0 (contact: positive flux).
  pure subroutine start_from_primal(mesh, u, is_gamma_a, bnd, x)
    type(mesh_t), intent(in) :: mesh
    real(dp), intent(in) :: u(:)
    logical, intent(in) :: is_gamma_a(:)
    real(dp), intent(in) :: bnd(:)
    real(dp), intent(inout) :: x(:)
    integer :: j, i, e, node, dof
    do j = 1, mesh%nbedge
      if (.not. is_gamma_a(j)) cycle
      e = mesh%bedge_edge(j)
      do i = 1, 2
        node = mesh%bedge_nodes(i, j)
        dof = 2 * (e - 1) + merge(1, 2, node == mesh%edge_nodes(1, e))
        if (u(node) > 0.0_dp) then
          x(dof) = bnd(dof)
        else
          x(dof) = bnd(dof) + 1.0_dp
        end if
      end do
    end do
  end subroutine start_from_primal

  !> x(dof) = mean over the (one or two) parameters sharing it of sgn * beta.
  subroutine average_to_global(map, beta, x, st)
    type(equilibrium_map_t), intent(in) :: map
    real(dp), intent(in) :: beta(:,:)
    real(dp), intent(out) :: x(:)
    type(status_t), intent(inout) :: st
    real(dp), allocatable :: cnt(:)
    integer :: t, k, ist
    allocate (cnt(size(x)), stat=ist)
    if (alloc_failed(ist, st, 'the flux averages', size(x), BYTES_REAL)) return
    cnt = 0.0_dp
    x = 0.0_dp
    do t = 1, map%ntri
      do k = 1, 6
        x(map%dof(k, t)) = x(map%dof(k, t)) + map%sgn(k, t) * beta(k, t)
        cnt(map%dof(k, t)) = cnt(map%dof(k, t)) + 1.0_dp
      end do
    end do
    x = x / cnt
  end subroutine average_to_global

  !> max over triangles of |d_t . beta_t| / (|d_t| . |beta_t|): the relative defect of (4.9).
  pure real(dp) function divergence_defect(d, beta) result(defect)
    real(dp), intent(in) :: d(:,:), beta(:,:)
    integer :: t
    real(dp) :: s
    defect = 0.0_dp
    do t = 1, size(d, 2)
      s = sum(abs(d(:, t) * beta(:, t)))
      if (s > 0.0_dp) defect = max(defect, abs(sum(d(:, t) * beta(:, t))) / s)
    end do
  end function divergence_defect
end module dualsig_problem_dual_p2
