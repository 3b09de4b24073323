!> The P2 equilibrium dual (4.5) by its stream function and multigrid: O(N) time and memory
!> (issue 16 item 3; doc/theory.md, "Dual problem of P2", Solvers, `multigrid`).
!>
!> With the polynomial particular field (lambda^f . nu = 0 on Gamma_a) the dual asks for the
!> divergence-free BDM1 field q (the equilibrium elements, continuity built in) minimising
!> 1/2 ||q||^2 + (lambda^f, q) with q . nu >= 0 at both ends of every Gamma_a edge.  On a
!> simply connected domain these fields are q = curl psi = (d psi/dy, -d psi/dx) with psi
!> continuous P2, unique up to a constant, and ||q||^2 = ||grad psi||^2.  The normal flux
!> of q at an end of an edge is the derivative of psi along the edge, so in the P2 values
!> psi (the vertices 1..nnode, then the edge midpoints nnode + e) the dual is
!>
!>     minimise 1/2 psi^T K psi - F^T psi   subject to  (G psi)_k >= 0 on Gamma_a,
!>
!> K the P2 stiffness matrix, G the map from psi to the global edge-end fluxes x of
!> dualsig_assembly_equilibrium (x = G psi, F = G^T b_x).  Sign convention of G: for edge e
!> with ends n1 < n2 and t = (x(n2) - x(n1)) / L, x(2e-1) and x(2e) are s_e d psi / dt at
!> n1 and n2, s_e = +1 when the triangle edge_tri(1, e) runs along the edge from n1 to n2
!> (its outward normal n_e is then t turned clockwise, and d psi / dt = curl psi . n_e).
!>
!> On a Gamma_a edge with ends a -> b in boundary order (domain on the left: d/dt is then
!> curl psi . nu) and midpoint m the two rows are
!>     c_1 = (-3 psi_a + 4 psi_m - psi_b) / L >= 0,   c_2 = (psi_a - 4 psi_m + 3 psi_b) / L >= 0,
!> three values, chained along Gamma_a: not bounds.  A primal-dual active set handles them:
!> with the set A of active rows fixed, the rows of A are eliminated by a change of basis
!> psi = R z (one active row: psi_m = (3 psi_a + psi_b) / 4 resp. (psi_a + 3 psi_b) / 4;
!> both: psi constant on the edge, a and b merged into one unknown, so a run of separated
!> Gamma_a edges becomes one unknown), and R^T K R z = R^T F is solved by multigrid: the
!> geometric hierarchy of the primal with one more grid P1 -> z of the finest mesh
!> (mg_extend_algebraic); without one, the same grid P1 -> z of the mesh and smoothed
!> aggregation of the P1 operator below it (p1_aggregated_hierarchy).  The multipliers
!> of A follow from K psi - F = C_A^T mu along each chain of Gamma_a edges (mu_of_chains);
!> a row leaves A when its multiplier is negative and joins it when it is violated.  The
!> start is the previous level's set where it tells (stream_prolongate_set), else the
!> primal's contact set (complementarity: the flux vanishes where u_h > 0).
!> The set is accepted when no multiplier is negative and no flux below -violation_tol
!> max|x|; what is left is removed by make_monotone, which keeps q a curl (exactly
!> divergence-free), so the field is admissible whatever the accuracy reached here, and the
!> caller's clipping and equilibration (as for every solver) only meet rounding.
!> psi's constant is fixed by a shift of the diagonal (constant_shift), not by a node.
module dualsig_dual_p2_stream
  use dualsig_kinds, only: dp, i8
  use dualsig_mesh, only: mesh_t
  use dualsig_elements_p2, only: p2_dofs, p2_element_stiffness
  use dualsig_dual_p2_sweeps, only: p2_sweeper_t, p2_sweeper_build, p2_sweep, p2_sweeper_fits
  use dualsig_sparse, only: csr_t, rect_t, rect_matvec, rect_matvec_t, rect_from_triplets, &
                            csr_pattern_from_cliques, csr_add_block
  use dualsig_amg_aggregation, only: amg_transpose, amg_galerkin_product
  use dualsig_solver_multigrid, only: mg_hierarchy_t, mg_settings_t, mg_result_t, multigrid_solve, mg_clear, &
                                      mg_build_algebraic, mg_extend_algebraic, mg_finest_size, &
                                      mg_extend_algebraic_take
  use dualsig_qp_types, only: BOUND_FREE
  use dualsig_status, only: status_t, set_error, set_warning, is_ok, is_warning, DS_ERR_INPUT, DS_ERR_NUMERIC, &
                            DS_WARN_NOT_CONVERGED
  use dualsig_strings, only: itoa
  use dualsig_alloc, only: alloc_failed, BYTES_REAL, BYTES_INT
  implicit none
  private

  public :: stream_settings_t, stream_result_t, stream_dual_solve, stream_flux_matrix, stream_stiffness, &
            stream_gamma_a_rows, stream_gamma_rows_t, stream_prolongate, stream_prolongate_set, &
            stream_prolongate_bisection, stream_prolongate_set_bisection, SET_ACTIVE, SET_FREE, SET_UNKNOWN, &
            stream_fluxes, stream_flux_load, stream_apply_stiffness, stream_reduced_basis, stream_reduced_stiffness

  !> A row of A leaves the active set when its multiplier is below -release_tol max|mu|, a
  !> free row joins it when its flux is below -violation_tol max|x|.  Smaller values are
  !> solver noise or degenerate rows at a contact/separation transition (multiplier and flux
  !> both about 0), which otherwise flip one per step: 4 steps instead of 1 at level 8 of
  !> p2_contact with 10^-8 and 10^-6.  What is left changes est by second order only (a
  !> violated row is lifted by make_monotone, the field stays admissible): measured, est
  !> moves by 1.4e-10 (level 7) and 3.5e-10 (level 8) relative (doc/performance.md).
  real(dp), parameter :: release_tol = 1.0e-6_dp
  real(dp), parameter :: violation_tol = 1.0e-5_dp
  !> The same when the solves stop at est_tol (an adaptive step's algebraic share): their
  !> residual is then about 10^-4 of the load, not 10^-8, and multipliers of 10^-5 max|mu|
  !> change sign from one solve to the next (doc/performance.md).  A row kept active with a
  !> small negative multiplier, or a small violation left to make_monotone, keeps the field
  !> admissible; only est's sharpness is at stake, by less than the share.
  real(dp), parameter :: release_tol_share = 1.0e-3_dp
  real(dp), parameter :: violation_tol_share = 1.0e-4_dp
  !> psi is defined up to a constant, R^T K R is semi-definite (R maps constants to
  !> constants; F = G^T b_x is orthogonal to them, G 1 = 0).  Its diagonal is raised by this
  !> fraction: the constants get a small positive energy, which every grid represents
  !> exactly (the prolongations keep constants), so multigrid keeps its h-independent rate;
  !> the non-constant part of psi moves by about this fraction times the condition number
  !> (1e-12 N; measured: est changes by 1e-9 relative at 10^6 unknowns).  Fixing the value
  !> of one node instead leaves near-constant modes of tiny energy that the coarse grids
  !> cannot correct: 25 V-cycles instead of 12 at 10^6 unknowns.
  real(dp), parameter :: constant_shift = 1.0e-12_dp
  !> V-cycles allowed to the hierarchy with the P1 grid and aggregation below it
  !> (p1_aggregated_hierarchy) before a step falls back on aggregating R^T K R itself: it
  !> needs 4-12 a step on the graded meshes of adaptive L-shape runs and on uniform meshes
  !> given as one level (it stalled on those until the aggregation kept the constants and
  !> the strong connections of a merged Gamma_a run, doc/performance.md); the fallback
  !> guards against a stall not seen yet
  integer, parameter :: p1_coarse_max_vcycles = 40
  !> smooth_first stops when the predicted part of J left is at most this fraction of
  !> energy_tol: the prediction (a geometric series of the sweeps' decreases) misses the
  !> smooth error the sweeps hardly reduce.  Measured at level 9 of p2_contact (share
  !> 10^-3): 6 sweeps, the stop at the full tolerance, left est 1.45 10^-3 above the
  !> multigrid solve's (effectivity 1.000798 against 1.000074); 8 sweeps, the stop at this
  !> fraction, 0.77 10^-3 (1.000459), within the share
  real(dp), parameter :: sweep_tol_fraction = 0.25_dp
  !> smooth_first gives up (the multigrid goes on) when a sweep leaves more than this
  !> fraction of the predicted part the sweep before left: what the sweeps reach then is the
  !> smooth error.  Measured (the predicted part, sweep by sweep from the third): p2_contact
  !> levels 8 and 9 shrink it by 0.38-0.56 a sweep and reach the share in 8; the L-shape with
  !> a contact transition at its corner (p2_lshape_load, level 8 of lshape n = 2) by 0.85,
  !> 0.50, 0.50, 0.58, 0.71, 0.86, 0.98 and stalls just above the share after 10: now given
  !> up after 3
  real(dp), parameter :: sweep_stall_ratio = 0.7_dp
  !> est as a function of psi is est_excess J(psi) + terms without psi: with lambda = lambda^f
  !> + curl psi, ||grad u~ - lambda||^2 + 2 int_{Gamma_a} u~ lambda.nu = ||grad u~ - lambda^f||^2
  !> + ||curl psi||^2 + 2 (lambda^f, curl psi) by Green's formula (div curl psi = 0, u~ = 0 on
  !> Gamma_u, lambda^f.nu = 0 on Gamma_a), so est - est* = 2 (J - J*) for the J of this module
  real(dp), parameter :: est_excess = 2.0_dp

  !> A Gamma_a row of a kept active set (stream_dual_solve's set_keep): its flux held at 0,
  !> free, or not known (rows off Gamma_a, rows at a new vertex whose edge was half active).
  integer, parameter :: SET_ACTIVE = 1, SET_FREE = 0, SET_UNKNOWN = -1

  !> Entries (r, c, v) of a sparse matrix being built, n of them so far (triplet_add).
  type :: triplets_t
    integer :: n = 0
    integer, allocatable :: r(:), c(:)
    real(dp), allocatable :: v(:)
  end type triplets_t

  type :: stream_settings_t
    real(dp) :: tol = 1.0e-8_dp      !! relative residual of each linear multigrid solve
    integer :: max_steps = 30        !! active-set steps
    !> > 0: a linear solve also stops when the part of est it could still remove is predicted
    !> below this (est units; est = 2 J(psi) + terms without psi, see est_excess below)
    real(dp) :: est_tol = 0.0_dp
    !> on the hierarchies without the refinements' grids (the P1 grid of the mesh and
    !> aggregation below it, or aggregation alone): conjugate gradients preconditioned by the
    !> V-cycle (mg_settings_t%krylov), whose energy contraction there is only about 0.3-0.4 per
    !> V-cycle; CG's per iteration was 0.03-0.04 on adaptive steps of p2_contact (7 iterations
    !> where the V-cycles took 7-10 to the algebraic share).  The geometric grids keep the
    !> plain V-cycles (7 to 1e-8 at every level) when solved to tol; with est_tol, CG too,
    !> for its energy stop (2 iterations to the share 1e-3 at level 9 of p2_contact, where the
    !> V-cycles took 5 to tol).
    logical :: krylov = .true.
    !> > 0, with est_tol > 0 and a start psi (the last level of a uniform run, from the
    !> previous level's psi): at most this many Gauss-Seidel sweeps on R^T K R before any
    !> multigrid; a step needs no hierarchy when they reach est_tol (smooth_first)
    integer :: smooth_sweeps = 0
  end type stream_settings_t

  type :: stream_result_t
    integer :: steps = 0             !! active-set steps (linear solves)
    integer :: vcycles = 0           !! multigrid iterations over all steps
    integer :: sweeps = 0            !! Gauss-Seidel sweeps of smooth_first over all steps
    logical :: hierarchy = .false.   !! a step used multigrid (else the sweeps reached est_tol in all)
    integer :: unknowns = 0          !! P2 values of psi
    integer :: nactive = 0           !! active Gamma_a rows at the end
    integer :: nrows = 0             !! Gamma_a rows
    logical :: geometric = .false.   !! the primal's geometric hierarchy was used (else aggregation)
    !> without it: z -> P1 of the mesh, aggregation below (p1_aggregated_hierarchy; else
    !> aggregation of R^T K R itself)
    logical :: p1_coarse = .false.
    logical :: converged = .false.   !! the active set settled and the last solve converged
    !> the part of est the last linear solve left, as predicted, when it stopped at est_tol
    !> (est units); 0 when it was solved to its residual tolerance
    real(dp) :: est_gap = 0.0_dp
  end type stream_result_t

  !> The Gamma_a edges in boundary order: edge k has ends a(k) -> b(k) (domain on the left),
  !> midpoint m(k) (a P2 index), length len(k), fluxes x(dof(1:2, k)) at a and b, and
  !> predecessor prev(k) (0: the previous boundary edge is not on Gamma_a).
  type :: stream_gamma_rows_t
    integer :: n = 0
    integer, allocatable :: a(:), b(:), m(:), dof(:,:), prev(:)
    integer, allocatable :: bedge(:)        !! the boundary edge (mesh%bedge_nodes) of row pair k
    real(dp), allocatable :: len(:)
  end type stream_gamma_rows_t

contains

  !> Solve the dual (module header) for the edge-end fluxes x (2 nedge) of q = curl psi.
  !> bx: the load of the fluxes (dualsig_problem_dual_p2, lambda^f polynomial);
  !> mg: the primal's geometric hierarchy (its finest grid the mesh's nodes), when there is
  !> one; u_primal: the primal solution, for the start of the active set; psi (optional):
  !> on entry, when of this mesh's size, the start (e.g. the previous level's psi,
  !> stream_prolongate), on return the solution; set_keep (optional, (2, nbedge)): on entry
  !> the rows known active or free (SET_ACTIVE, SET_FREE; SET_UNKNOWN: the primal's guess),
  !> e.g. the previous level's set (stream_prolongate_set), on return the final set.
  !> st: DS_ERR_INPUT (a domain with holes), DS_ERR_MEMORY, DS_ERR_NUMERIC;
  !> DS_WARN_NOT_CONVERGED when the active set did not settle or a solve stopped early.
  subroutine stream_dual_solve(mesh, bx, is_gamma_a, x, settings, res, st, mg, u_primal, psi_keep, set_keep)
    type(mesh_t), intent(in) :: mesh
    real(dp), intent(in) :: bx(:)
    logical, intent(in) :: is_gamma_a(:)
    real(dp), intent(out) :: x(:)
    type(stream_settings_t), intent(in) :: settings
    type(stream_result_t), intent(out) :: res
    type(status_t), intent(out) :: st
    type(mg_hierarchy_t), intent(in), optional :: mg
    real(dp), intent(in), optional :: u_primal(:)
    real(dp), allocatable, intent(inout), optional :: psi_keep(:)
    integer, allocatable, intent(inout), optional :: set_keep(:,:)
    type(stream_gamma_rows_t) :: rows
    real(dp), allocatable :: f(:), psi(:), r(:), mu(:,:)
    logical, allocatable :: active(:,:), next(:,:), at_rows(:)
    integer :: n2, step, ist
    logical :: last_ok, try_p1

    if (mesh%nloop /= 1) then
      call set_error(st, DS_ERR_INPUT, 'dual P2, method multigrid: the stream function needs a simply connected ' // &
        'domain (this mesh has ' // itoa(mesh%nloop - 1) // ' holes); use &dual method = ''augmented''')
      return
    end if
    n2 = mesh%nnode + mesh%nedge
    res%unknowns = n2
    call stream_gamma_a_rows(mesh, is_gamma_a, rows, st)
    if (.not. is_ok(st)) return
    res%nrows = 2 * rows%n
    allocate (f(n2), psi(n2), mu(2, rows%n), active(2, rows%n), next(2, rows%n), stat=ist)
    if (alloc_failed(ist, st, 'the stream function', 2_i8 * n2 + 4_i8 * rows%n, BYTES_REAL)) return
    call stream_flux_load(mesh, bx, f)
    active = .false.
    if (present(u_primal)) then
      active(1, :) = u_primal(rows%a) > 0.0_dp
      active(2, :) = u_primal(rows%b) > 0.0_dp
    end if
    if (present(set_keep)) then                  ! the previous level's set where it tells
      if (allocated(set_keep)) then
        if (size(set_keep, 2) == mesh%nbedge) then
          where (set_keep(:, rows%bedge) /= SET_UNKNOWN) active = set_keep(:, rows%bedge) == SET_ACTIVE
        end if
      end if
    end if
    psi = 0.0_dp
    if (present(psi_keep)) then
      if (allocated(psi_keep)) then
        if (size(psi_keep) == n2) psi = psi_keep
      end if
    end if
    last_ok = .false.
    try_p1 = .true.
    do step = 1, settings%max_steps
      res%steps = step
      call solve_with_active(mesh, f, rows, active, settings, psi, res, last_ok, try_p1, st, mg)
      if (.not. is_ok(st)) return
      call stream_fluxes(mesh, psi, x)
      allocate (r(n2), at_rows(n2), stat=ist)   ! not held during the solves (their memory is the peak)
      if (alloc_failed(ist, st, 'the stream residual', int(n2, i8), BYTES_REAL + 1)) return
      call gamma_a_residual(mesh, rows, psi, f, at_rows, r)
      deallocate (at_rows)
      call mu_of_chains(rows, active, r, mu)
      deallocate (r)
      if (settings%est_tol > 0.0_dp) then
        call next_active(rows, active, mu, x, release_tol_share, violation_tol_share, next)
      else
        call next_active(rows, active, mu, x, release_tol, violation_tol, next)
      end if
      if (all(next .eqv. active)) then
        res%converged = last_ok
        exit
      end if
      active = next
    end do
    res%nactive = count(active)
    call make_monotone(rows, psi)
    call stream_fluxes(mesh, psi, x)
    if (present(psi_keep)) call move_alloc(psi, psi_keep)
    if (present(set_keep)) then
      if (allocated(set_keep)) deallocate (set_keep)
      allocate (set_keep(2, mesh%nbedge), source=SET_UNKNOWN, stat=ist)
      if (alloc_failed(ist, st, 'the active set on Gamma_a', 2_i8 * mesh%nbedge, BYTES_INT)) return
      set_keep(:, rows%bedge) = merge(SET_ACTIVE, SET_FREE, active)
    end if
    if (.not. res%converged) call set_warning(st, DS_WARN_NOT_CONVERGED, 'dual P2, method multigrid: the active ' // &
      'set on Gamma_a did not settle in ' // itoa(settings%max_steps) // ' steps, or a linear solve stopped early ' // &
      '(the field is made admissible all the same; the bound stays guaranteed, less sharp)')
  end subroutine stream_dual_solve

  !> One step: psi = R z with R^T K R z = R^T F for the active rows (module header), z
  !> started from psi, solved by multigrid.  last_ok: the solve converged.
  subroutine solve_with_active(mesh, f, rows, active, settings, psi, res, last_ok, try_p1, st, mg)
    type(mesh_t), intent(in) :: mesh
    real(dp), intent(in) :: f(:)
    type(stream_gamma_rows_t), intent(in) :: rows
    logical, intent(in) :: active(:,:)
    type(stream_settings_t), intent(in) :: settings
    real(dp), intent(inout) :: psi(:)
    type(stream_result_t), intent(inout) :: res
    logical, intent(out) :: last_ok
    logical, intent(inout) :: try_p1
    type(status_t), intent(inout) :: st
    type(mg_hierarchy_t), intent(in), optional :: mg
    type(rect_t) :: rmat, pz
    type(csr_t) :: kz
    type(mg_hierarchy_t) :: h
    type(mg_settings_t) :: ms
    type(mg_result_t) :: mr
    type(status_t) :: st_mg
    integer, allocatable :: node_of_z(:), kind(:)
    real(dp), allocatable :: fz(:), z(:), bnd(:), xyz(:,:)
    integer :: nz, i, ist, max_iter_default

    last_ok = .false.
    call stream_reduced_basis(mesh, rows, active, rmat, node_of_z=node_of_z, st=st)
    if (.not. is_ok(st)) return
    nz = rmat%n
    allocate (fz(nz), z(nz), stat=ist)
    if (alloc_failed(ist, st, 'the reduced stream function', 2_i8 * nz, BYTES_REAL)) return
    call rect_matvec_t(rmat, f, fz)
    z = psi(node_of_z)
    if (settings%smooth_sweeps > 0 .and. settings%est_tol > 0.0_dp .and. any(z /= 0.0_dp) .and. &
        p2_sweeper_fits(mesh)) then
      call rect_matvec(rmat, z, psi)        ! the start in the range of R
      call smooth_first(mesh, rmat, node_of_z, fz, settings%smooth_sweeps, settings%est_tol / est_excess, psi, &
                        res, last_ok, st)
      if (.not. is_ok(st) .or. last_ok) return
      z = psi(node_of_z)                    ! the V-cycles go on from the swept psi
    end if
    call stream_p1_prolongation(mesh, node_of_z, pz, st)
    if (.not. is_ok(st)) return
    call stream_reduced_stiffness(mesh, rmat, kz, st)
    if (.not. is_ok(st)) return
    allocate (bnd(nz), kind(nz), stat=ist)
    if (alloc_failed(ist, st, 'the reduced stream function', 2_i8 * nz, BYTES_REAL)) return
    kind = BOUND_FREE
    bnd = 0.0_dp
    kz%val(kz%diag) = kz%val(kz%diag) * (1.0_dp + constant_shift)
    res%hierarchy = .true.
    res%geometric = .false.
    if (present(mg)) then
      if (mg%nlevel >= 2 .and. mg_finest_size(mg) == mesh%nnode) then
        call mg_extend_algebraic(mg, pz, h, st)
        if (.not. is_ok(st)) return
        res%geometric = .true.
      end if
    end if
    ms%tol = settings%tol
    ms%energy_tol = settings%est_tol / est_excess
    ms%fmg_cycles = merge(1, 0, all(z == 0.0_dp))
    max_iter_default = ms%max_iter
    res%p1_coarse = .false.
    ms%krylov = settings%krylov .and. (.not. res%geometric .or. settings%est_tol > 0.0_dp)
    if (.not. res%geometric .and. try_p1) then
      call p1_aggregated_hierarchy(mesh, kz, pz, h, res%p1_coarse)
      if (res%p1_coarse) then
        ms%max_iter = p1_coarse_max_vcycles
        call multigrid_solve(h, kz, fz, kind, bnd, z, ms, mr, st_mg)
        call mg_clear(h)
        res%vcycles = res%vcycles + mr%iterations
        if (.not. mr%converged) then           ! stalled: aggregation of R^T K R from here on
          try_p1 = .false.
          res%p1_coarse = .false.
          z = psi(node_of_z)
        end if
      end if
      try_p1 = res%p1_coarse
    end if
    if (.not. (res%geometric .or. res%p1_coarse)) then     ! aggregation of R^T K R itself
      allocate (xyz(2, nz), stat=ist)
      if (alloc_failed(ist, st, 'the coordinates of the stream function', 2_i8 * nz, BYTES_REAL)) return
      do i = 1, nz
        xyz(:, i) = p2_point(mesh, node_of_z(i))
      end do
      call mg_build_algebraic(h, kz, st, xyz)
      if (.not. is_ok(st)) return
    end if
    if (.not. res%p1_coarse) then
      ms%max_iter = max_iter_default
      call multigrid_solve(h, kz, fz, kind, bnd, z, ms, mr, st_mg)
      call mg_clear(h)
      res%vcycles = res%vcycles + mr%iterations
    end if
    if (.not. is_ok(st_mg) .and. .not. is_warning(st_mg)) then
      st = st_mg
      return
    end if
    last_ok = mr%converged
    res%est_gap = 0.0_dp                    ! (energy_gap is huge when no prediction was made)
    if (mr%energy_stop) res%est_gap = est_excess * mr%energy_gap
    call rect_matvec(rmat, z, psi)
  end subroutine solve_with_active

  !> Gauss-Seidel sweeps (forward, backward, ...) on R^T K R z = fz (with constant_shift)
  !> from a close start psi = R z (the previous level's psi), matrix-free and without a
  !> hierarchy (dualsig_dual_p2_sweeps): they remove the error's oscillating part, which is
  !> most of what a prolongated start leaves (its smooth part is of higher order; theory.md,
  !> "Inexact solves ... the algebraic share").  done: the part of J the sweeps could still
  !> remove, predicted from the last two sweeps' decreases dj as a geometric series (dj q /
  !> (1 - q), q their ratio; after the first sweep dj itself), is at most sweep_tol_fraction
  !> energy_tol (J's units), within max_sweeps; otherwise (also as soon as the remaining
  !> sweeps would not get there at the ratio measured, or a sweep stops contracting) the
  !> caller goes on with multigrid from the swept psi (the sweeps are not lost).
  !> res%est_gap: the prediction.  st: DS_ERR_MEMORY.
  subroutine smooth_first(mesh, rmat, node_of_z, fz, max_sweeps, energy_tol, psi, res, done, st)
    type(mesh_t), intent(in) :: mesh
    type(rect_t), intent(in) :: rmat
    integer, intent(in) :: node_of_z(:)
    real(dp), intent(in) :: fz(:)
    integer, intent(in) :: max_sweeps
    real(dp), intent(in) :: energy_tol
    real(dp), intent(inout) :: psi(:)
    type(stream_result_t), intent(inout) :: res
    logical, intent(out) :: done
    type(status_t), intent(inout) :: st
    type(p2_sweeper_t) :: sw
    real(dp) :: dj, dj_prev, left, left_prev, q, target
    integer :: k
    done = .false.
    call p2_sweeper_build(mesh, rmat, node_of_z, sw, st)
    if (.not. is_ok(st)) return
    target = sweep_tol_fraction * energy_tol
    left = huge(1.0_dp)
    dj = 0.0_dp
    do k = 1, max_sweeps
      dj_prev = dj
      left_prev = left
      call p2_sweep(mesh, sw, fz, constant_shift, psi, mod(k, 2) == 1, dj)
      res%sweeps = res%sweeps + 1
      q = 0.0_dp
      if (k == 1 .or. .not. dj > 0.0_dp) then
        left = dj
      else if (dj < dj_prev) then
        q = dj / dj_prev
        left = dj * q / (1.0_dp - q)
      else
        exit                                ! no contraction measured
      end if
      done = left <= target
      if (done) exit
      ! the sweeps still allowed would not get there at the rate measured, or what they
      ! leave has stopped shrinking (the smooth error, which needs the coarse grids): multigrid now
      if (k >= 2 .and. left * q**(max_sweeps - k) > target) exit
      if (k >= 3 .and. left > sweep_stall_ratio * left_prev) exit
    end do
    res%est_gap = 0.0_dp
    if (done) res%est_gap = est_excess * left
  end subroutine smooth_first

  !> The hierarchy for a mesh without refinements (level 1, Gmsh meshes, adaptive steps):
  !> z -> P1 of the mesh by pz, as on the geometric grids, and below the P1 grid smoothed
  !> aggregation of its operator Pz^T Kz Pz, a P1 stiffness matrix (with the Gamma_a
  !> merges), where aggregation works as for the primal; aggregating the P2 matrix R^T K R
  !> itself (positive off-diagonal entries, two kinds of nodes) needed 11-107 V-cycles on
  !> the graded meshes of an adaptive run (doc/performance.md).  built: .false. when
  !> the P1 operator could not be built or aggregated (memory, no coarsening; the caller
  !> then aggregates R^T K R).
  subroutine p1_aggregated_hierarchy(mesh, kz, pz, h, built)
    type(mesh_t), intent(in) :: mesh
    type(csr_t), intent(in) :: kz
    type(rect_t), intent(inout) :: pz              !! moved into h (mg_extend_algebraic)
    type(mg_hierarchy_t), intent(inout) :: h
    logical, intent(out) :: built
    type(rect_t) :: pzt
    type(csr_t) :: kc
    type(mg_hierarchy_t) :: h1
    type(status_t) :: st
    built = .false.
    if (pz%n /= mesh%nnode) return
    call amg_transpose(pz, pzt, st)
    if (is_ok(st)) call amg_galerkin_product(pz, pzt, kz, kc, st)
    pzt = rect_t()                                 ! freed (general_transfer makes it again)
    if (is_ok(st)) call mg_build_algebraic(h1, kc, st, mesh%xy)
    ! kc and the aggregation's coarse operators become h's: its solve (with kz) does not
    ! recompute them
    if (is_ok(st)) call mg_extend_algebraic_take(h1, pz, h, st, kc)
    call mg_clear(h1)
    built = is_ok(st)
    if (.not. built) call mg_clear(h)
  end subroutine p1_aggregated_hierarchy

  !> psi_f = psi_c on the red refinement `fine` of `coarse` (dualsig_mesh_refine's numbering):
  !> the P2 function is unchanged.  The fine vertices are the coarse P2 nodes, with the same
  !> numbers (coarse vertex i, coarse midpoint nnode + e); a fine midpoint takes the value of
  !> the parent's quadratic at its barycentric coordinates.
  subroutine stream_prolongate(coarse, fine, psi_c, psi_f, st)
    type(mesh_t), intent(in) :: coarse, fine
    real(dp), intent(in) :: psi_c(:)
    real(dp), allocatable, intent(out) :: psi_f(:)
    type(status_t), intent(out) :: st
    ! barycentric coordinates (in the parent) of v1, v2, v3, m1, m2, m3 and the children's
    ! vertices (as indices into them), dualsig_mesh_refine's layout
    real(dp), parameter :: b(3, 6) = reshape([1.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 1.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, &
      1.0_dp, 0.5_dp, 0.5_dp, 0.0_dp, 0.0_dp, 0.5_dp, 0.5_dp, 0.5_dp, 0.0_dp, 0.5_dp], [3, 6])
    integer, parameter :: child(3, 4) = reshape([1, 4, 6, 4, 2, 5, 6, 5, 3, 4, 5, 6], [3, 4])
    real(dp) :: lam(3), vals(6)
    integer :: t, c, i, tf, ist
    allocate (psi_f(fine%nnode + fine%nedge), stat=ist)
    if (alloc_failed(ist, st, 'the prolongated stream function', int(fine%nnode + fine%nedge, i8), BYTES_REAL)) &
      return
    psi_f(1:coarse%nnode + coarse%nedge) = psi_c
    do t = 1, coarse%ntri
      vals(1:3) = psi_c(coarse%tri(:, t))
      vals(4:6) = psi_c(coarse%nnode + coarse%tri_edge(:, t))
      do c = 1, 4
        tf = 4 * (t - 1) + c
        do i = 1, 3
          lam = 0.5_dp * (b(:, child(i, c)) + b(:, child(mod(i, 3) + 1, c)))
          psi_f(fine%nnode + fine%tri_edge(i, tf)) = p2_value(vals, lam)
        end do
      end do
    end do
  end subroutine stream_prolongate

  !> The active set of the rows (set_keep of stream_dual_solve, (2, nbedge) of the coarse
  !> mesh) carried to the red refinement: coarse boundary edge j (a -> b, midpoint m) becomes
  !> fine edges 2j-1 = (a, m) and 2j = (m, b) (dualsig_mesh_refine); the rows at a and b keep
  !> their state, the two at m are active when both rows of j were (the flux vanished on the
  !> whole edge), free when neither was, unknown otherwise.
  subroutine stream_prolongate_set(set_c, set_f, st)
    integer, intent(in) :: set_c(:,:)
    integer, allocatable, intent(out) :: set_f(:,:)
    type(status_t), intent(out) :: st
    integer :: j, mid, ist
    allocate (set_f(2, 2 * size(set_c, 2)), stat=ist)
    if (alloc_failed(ist, st, 'the prolongated active set', 4_i8 * size(set_c, 2), BYTES_INT)) return
    do j = 1, size(set_c, 2)
      mid = midpoint_state(set_c(:, j))
      set_f(:, 2 * j - 1) = [set_c(1, j), mid]
      set_f(:, 2 * j) = [mid, set_c(2, j)]
    end do
  end subroutine stream_prolongate_set

  !> The state of the two rows at the midpoint of a split Gamma_a edge whose end rows are
  !> ends: active when both were (the flux vanished on the whole edge), free when neither
  !> was, unknown otherwise.
  pure integer function midpoint_state(ends) result(mid)
    integer, intent(in) :: ends(2)
    mid = SET_UNKNOWN
    if (all(ends == SET_ACTIVE)) mid = SET_ACTIVE
    if (all(ends == SET_FREE)) mid = SET_FREE
  end function midpoint_state

  !> psi_f = psi_c on the newest-vertex bisection `fine` of `coarse` (mesh_refine_marked:
  !> fine node coarse%nnode + k is the midpoint of the coarse edge parents(:, k), numbered in
  !> coarse edge order): the P2 function is unchanged.  A new vertex takes the coarse
  !> midpoint value; every fine edge midpoint lies in a coarse triangle T that holds both
  !> its ends (a coarse vertex of T or the midpoint of an edge of T), and takes the value of
  !> psi_c on T at the mean of their barycentric coordinates (a half of a split edge or an
  !> unsplit edge: the trace on that edge, the same from either side).  st: DS_ERR_MEMORY;
  !> DS_ERR_NUMERIC when a fine edge has no such triangle (not a bisection of coarse).
  subroutine stream_prolongate_bisection(coarse, fine, parents, psi_c, psi_f, st)
    type(mesh_t), intent(in) :: coarse, fine
    integer, intent(in) :: parents(:,:)
    real(dp), intent(in) :: psi_c(:)
    real(dp), allocatable, intent(out) :: psi_f(:)
    type(status_t), intent(out) :: st
    integer, allocatable :: ekof(:), start(:), nbr(:), nedg(:)
    integer :: nn, k, e, f, ist, t, side, ends(2)
    real(dp) :: lam(3), vals(6)
    nn = coarse%nnode
    allocate (psi_f(fine%nnode + fine%nedge), ekof(size(parents, 2)), start(nn + 1), nbr(2 * coarse%nedge), &
              nedg(2 * coarse%nedge), stat=ist)
    if (alloc_failed(ist, st, 'the prolongated stream function', int(fine%nnode + fine%nedge, i8) + &
        4_i8 * coarse%nedge, BYTES_REAL)) return
    k = 0
    do e = 1, coarse%nedge                ! the split edges, in edge order
      if (k == size(parents, 2)) exit
      if (all(coarse%edge_nodes(:, e) == parents(:, k + 1))) then
        k = k + 1
        ekof(k) = e
      end if
    end do
    if (k /= size(parents, 2)) then
      call set_error(st, DS_ERR_NUMERIC, 'stream_prolongate_bisection: a new vertex is not an edge midpoint')
      return
    end if
    call node_edges(coarse, start, nbr, nedg)
    psi_f(1:nn) = psi_c(1:nn)
    psi_f(nn + 1:nn + k) = psi_c(nn + ekof)
    do f = 1, fine%nedge
      ends = fine%edge_nodes(:, f)
      if (all(ends <= nn)) then            ! an unsplit coarse edge
        e = edge_between(ends(1), ends(2))
        if (e == 0) exit
        psi_f(fine%nnode + f) = psi_c(nn + e)
        cycle
      end if
      if (ends(1) > nn) then
        e = ekof(ends(1) - nn)
      else
        e = ekof(ends(2) - nn)
      end if
      t = 0
      do side = 1, 2
        if (coarse%edge_tri(side, e) > 0) then
          if (holds(coarse%edge_tri(side, e), ends(1)) .and. holds(coarse%edge_tri(side, e), ends(2))) &
            t = coarse%edge_tri(side, e)
        end if
      end do
      if (t == 0) exit
      lam = 0.5_dp * (bary_of(t, ends(1)) + bary_of(t, ends(2)))
      vals(1:3) = psi_c(coarse%tri(:, t))
      vals(4:6) = psi_c(nn + coarse%tri_edge(:, t))
      psi_f(fine%nnode + f) = p2_value(vals, lam)
    end do
    if (f <= fine%nedge) call set_error(st, DS_ERR_NUMERIC, 'stream_prolongate_bisection: fine edge ' // itoa(f) // &
      ' lies in no coarse triangle')
  contains
    !> The coarse edge between coarse nodes a and b (0: none).
    integer function edge_between(a, b) result(ee)
      integer, intent(in) :: a, b
      integer :: q
      ee = 0
      do q = start(a), start(a + 1) - 1
        if (nbr(q) == b) ee = nedg(q)
      end do
    end function edge_between
    !> Coarse triangle tt holds fine node i: i is one of its vertices, or the midpoint of one
    !> of its edges.
    logical function holds(tt, i)
      integer, intent(in) :: tt, i
      if (i <= nn) then
        holds = any(coarse%tri(:, tt) == i)
      else
        holds = any(coarse%tri_edge(:, tt) == ekof(i - nn))
      end if
    end function holds
    !> The barycentric coordinates of fine node i in coarse triangle tt (holds(tt, i)).
    function bary_of(tt, i) result(b)
      integer, intent(in) :: tt, i
      real(dp) :: b(3)
      integer :: q
      b = 0.0_dp
      do q = 1, 3
        if (i <= nn) then
          if (coarse%tri(q, tt) == i) b(q) = 1.0_dp
        else if (coarse%tri_edge(q, tt) == ekof(i - nn)) then
          b(q) = 0.5_dp
          b(mod(q, 3) + 1) = 0.5_dp
        end if
      end do
    end function bary_of
  end subroutine stream_prolongate_bisection

  !> The coarse node-to-edge lists: the edges at node i are nedg(start(i):start(i+1)-1),
  !> their other ends nbr(...).
  pure subroutine node_edges(mesh, start, nbr, nedg)
    type(mesh_t), intent(in) :: mesh
    integer, intent(out) :: start(:), nbr(:), nedg(:)
    integer :: e, i, a, b
    start = 0
    do e = 1, mesh%nedge
      a = mesh%edge_nodes(1, e)
      b = mesh%edge_nodes(2, e)
      start(a + 1) = start(a + 1) + 1
      start(b + 1) = start(b + 1) + 1
    end do
    start(1) = 1
    do i = 1, mesh%nnode
      start(i + 1) = start(i + 1) + start(i)
    end do
    do e = 1, mesh%nedge
      a = mesh%edge_nodes(1, e)
      b = mesh%edge_nodes(2, e)
      nbr(start(a)) = b
      nedg(start(a)) = e
      start(a) = start(a) + 1
      nbr(start(b)) = a
      nedg(start(b)) = e
      start(b) = start(b) + 1
    end do
    do i = mesh%nnode, 1, -1
      start(i + 1) = start(i)
    end do
    start(1) = 1
  end subroutine node_edges

  !> The active set of the rows (set_keep, (2, nbedge) of coarse) carried to the bisection
  !> `fine` (mesh_refine_marked's split_boundary: the boundary edges in order, a split edge
  !> followed by its halves (a, m), (m, b)): an unsplit edge keeps its rows, a split one as
  !> in stream_prolongate_set.
  subroutine stream_prolongate_set_bisection(coarse, fine, set_c, set_f, st)
    type(mesh_t), intent(in) :: coarse, fine
    integer, intent(in) :: set_c(:,:)
    integer, allocatable, intent(out) :: set_f(:,:)
    type(status_t), intent(out) :: st
    integer :: j, nb, mid, ist
    allocate (set_f(2, fine%nbedge), source=SET_UNKNOWN, stat=ist)
    if (alloc_failed(ist, st, 'the prolongated active set', 2_i8 * fine%nbedge, BYTES_INT)) return
    nb = 0
    do j = 1, coarse%nbedge
      if (nb + 1 > fine%nbedge) exit
      if (all(fine%bedge_nodes(:, nb + 1) == coarse%bedge_nodes(:, j))) then
        nb = nb + 1
        set_f(:, nb) = set_c(:, j)
      else
        if (nb + 2 > fine%nbedge) exit
        mid = midpoint_state(set_c(:, j))
        set_f(:, nb + 1) = [set_c(1, j), mid]
        set_f(:, nb + 2) = [mid, set_c(2, j)]
        nb = nb + 2
      end if
    end do
    if (nb /= fine%nbedge) set_f = SET_UNKNOWN      ! not the bisection's boundary: no start
  end subroutine stream_prolongate_set_bisection

  !> The P2 function with vertex values vals(1:3) and edge values vals(4:6) (edge i from
  !> vertex i to i+1) at barycentric coordinates lam.
  pure real(dp) function p2_value(vals, lam) result(v)
    real(dp), intent(in) :: vals(6), lam(3)
    integer :: i
    v = 0.0_dp
    do i = 1, 3
      v = v + vals(i) * lam(i) * (2 * lam(i) - 1) + vals(3 + i) * 4 * lam(i) * lam(mod(i, 3) + 1)
    end do
  end function p2_value

  !> The coordinates of P2 node i (a vertex, or the midpoint of edge i - nnode).
  pure function p2_point(mesh, i) result(p)
    type(mesh_t), intent(in) :: mesh
    integer, intent(in) :: i
    real(dp) :: p(2)
    if (i <= mesh%nnode) then
      p = mesh%xy(:, i)
    else
      p = 0.5_dp * (mesh%xy(:, mesh%edge_nodes(1, i - mesh%nnode)) + mesh%xy(:, mesh%edge_nodes(2, i - mesh%nnode)))
    end if
  end function p2_point

  !> G (2 nedge x (nnode + nedge)): the edge-end fluxes x = G psi of q = curl psi (module
  !> header: three entries per row, the derivative of the P2 trace along the edge).  The
  !> solver applies G without storing it (stream_fluxes, stream_flux_load).
  subroutine stream_flux_matrix(mesh, g, st)
    type(mesh_t), intent(in) :: mesh
    type(rect_t), intent(out) :: g
    type(status_t), intent(out) :: st
    integer, allocatable :: ri(:), ci(:)
    real(dp), allocatable :: v(:)
    integer :: e, p, ist
    allocate (ri(6 * mesh%nedge), ci(6 * mesh%nedge), v(6 * mesh%nedge), stat=ist)
    if (alloc_failed(ist, st, 'the flux map of the stream function', 6_i8 * mesh%nedge, BYTES_REAL + 2 * BYTES_INT)) &
      return
    do e = 1, mesh%nedge
      p = 6 * (e - 1)
      ri(p + 1:p + 3) = 2 * e - 1
      ri(p + 4:p + 6) = 2 * e
      ci(p + 1:p + 6) = [mesh%edge_nodes(1, e), mesh%nnode + e, mesh%edge_nodes(2, e), mesh%edge_nodes(1, e), &
                         mesh%nnode + e, mesh%edge_nodes(2, e)]
      v(p + 1:p + 6) = flux_scale(mesh, e) * [-3.0_dp, 4.0_dp, -1.0_dp, 1.0_dp, -4.0_dp, 3.0_dp]
    end do
    call rect_from_triplets(2 * mesh%nedge, mesh%nnode + mesh%nedge, ri, ci, v, g, st)
  end subroutine stream_flux_matrix

  !> s_e / L_e of edge e (module header: the sign of G's rows and the edge's length).
  pure real(dp) function flux_scale(mesh, e) result(w)
    type(mesh_t), intent(in) :: mesh
    integer, intent(in) :: e
    real(dp) :: d(2)
    integer :: n1, t, kl
    n1 = mesh%edge_nodes(1, e)
    d = mesh%xy(:, mesh%edge_nodes(2, e)) - mesh%xy(:, n1)
    t = mesh%edge_tri(1, e)
    w = -1.0_dp
    do kl = 1, 3
      if (mesh%tri_edge(kl, t) == e .and. mesh%tri(kl, t) == n1) w = 1.0_dp
    end do
    w = w / sqrt(d(1)**2 + d(2)**2)
  end function flux_scale

  !> x = G psi (stream_flux_matrix), edge by edge.
  pure subroutine stream_fluxes(mesh, psi, x)
    type(mesh_t), intent(in) :: mesh
    real(dp), intent(in) :: psi(:)
    real(dp), intent(out) :: x(:)
    real(dp) :: w, pa, pm, pb
    integer :: e
    do e = 1, mesh%nedge
      w = flux_scale(mesh, e)
      pa = psi(mesh%edge_nodes(1, e))
      pm = psi(mesh%nnode + e)
      pb = psi(mesh%edge_nodes(2, e))
      x(2 * e - 1) = w * (-3.0_dp * pa + 4.0_dp * pm - pb)
      x(2 * e) = w * (pa - 4.0_dp * pm + 3.0_dp * pb)
    end do
  end subroutine stream_fluxes

  !> f = G^T bx (stream_flux_matrix), edge by edge.
  pure subroutine stream_flux_load(mesh, bx, f)
    type(mesh_t), intent(in) :: mesh
    real(dp), intent(in) :: bx(:)
    real(dp), intent(out) :: f(:)
    real(dp) :: w, x1, x2
    integer :: e, n1, n2
    f = 0.0_dp
    do e = 1, mesh%nedge
      w = flux_scale(mesh, e)
      x1 = w * bx(2 * e - 1)
      x2 = w * bx(2 * e)
      n1 = mesh%edge_nodes(1, e)
      n2 = mesh%edge_nodes(2, e)
      f(n1) = f(n1) - 3.0_dp * x1 + x2
      f(mesh%nnode + e) = f(mesh%nnode + e) + 4.0_dp * (x1 - x2)
      f(n2) = f(n2) - x1 + 3.0_dp * x2
    end do
  end subroutine stream_flux_load

  !> r = K psi - F at the ends and midpoints of the Gamma_a rows, what mu_of_chains reads
  !> (0 elsewhere), from the triangles that hold one of them: the element products of those
  !> only, O(sqrt N) of them.  at: work array (n2), on return .true. at those nodes.
  pure subroutine gamma_a_residual(mesh, rows, psi, f, at, r)
    type(mesh_t), intent(in) :: mesh
    type(stream_gamma_rows_t), intent(in) :: rows
    real(dp), intent(in) :: psi(:), f(:)
    logical, intent(out) :: at(:)
    real(dp), intent(out) :: r(:)
    real(dp) :: ke(6, 6)
    integer :: t, cl(6)
    at = .false.
    at(rows%a) = .true.
    at(rows%b) = .true.
    at(rows%m) = .true.
    r = 0.0_dp
    do t = 1, mesh%ntri
      cl = p2_dofs(mesh, t)
      if (.not. any(at(cl(1:3)))) cycle        ! a triangle with a node of the rows has a vertex there
      call p2_element_stiffness(mesh%xy(:, mesh%tri(:, t)), ke)
      r(cl) = r(cl) + matmul(ke, psi(cl))
    end do
    where (at) r = r - f
    where (.not. at) r = 0.0_dp
  end subroutine gamma_a_residual

  !> K: the P2 stiffness matrix (int grad phi_i . grad phi_j), vertices first, then the
  !> edge midpoints.  The solver assembles R^T K R directly (stream_reduced_stiffness) and applies K
  !> element by element (stream_apply_stiffness); K itself is for the tests.
  subroutine stream_stiffness(mesh, k, st)
    type(mesh_t), intent(in) :: mesh
    type(csr_t), intent(out) :: k
    type(status_t), intent(out) :: st
    integer, allocatable :: cl(:,:)
    real(dp) :: ke(6, 6)
    integer :: t, ist
    allocate (cl(6, mesh%ntri), stat=ist)
    if (alloc_failed(ist, st, 'the P2 element map', 6_i8 * mesh%ntri, BYTES_INT)) return
    do t = 1, mesh%ntri
      cl(:, t) = p2_dofs(mesh, t)
    end do
    call csr_pattern_from_cliques(mesh%nnode + mesh%nedge, cl, k, st)
    if (.not. is_ok(st)) return
    k%val = 0.0_dp
    do t = 1, mesh%ntri
      call p2_element_stiffness(mesh%xy(:, mesh%tri(:, t)), ke)
      call csr_add_block(k, cl(:, t), ke)
    end do
  end subroutine stream_stiffness

  !> kpsi = K psi (stream_stiffness), element by element.
  pure subroutine stream_apply_stiffness(mesh, psi, kpsi)
    type(mesh_t), intent(in) :: mesh
    real(dp), intent(in) :: psi(:)
    real(dp), intent(out) :: kpsi(:)
    real(dp) :: ke(6, 6)
    integer :: t, cl(6)
    kpsi = 0.0_dp
    do t = 1, mesh%ntri
      cl = p2_dofs(mesh, t)
      call p2_element_stiffness(mesh%xy(:, mesh%tri(:, t)), ke)
      kpsi(cl) = kpsi(cl) + matmul(ke, psi(cl))
    end do
  end subroutine stream_apply_stiffness

  !> kz = R^T K R (stream_reduced_basis), assembled element by element without K: element t adds
  !> R_t^T K_t R_t, R_t the rows of R at its P2 values.  Every row of R has one or two
  !> entries, and the second entry of a row (an eliminated midpoint) is the first entry of an
  !> end of its edge, a value of the same triangle: the first entries of the six rows hold
  !> all columns of R_t, the element's clique in z.
  subroutine stream_reduced_stiffness(mesh, rmat, kz, st)
    type(mesh_t), intent(in) :: mesh
    type(rect_t), intent(in) :: rmat
    type(csr_t), intent(out) :: kz
    type(status_t), intent(inout) :: st
    integer, allocatable :: cz(:,:)
    real(dp) :: ke(6, 6), w
    integer :: t, i, j, p, q, r, cl(6), ist
    allocate (cz(6, mesh%ntri), stat=ist)
    if (alloc_failed(ist, st, 'the reduced element map', 6_i8 * mesh%ntri, BYTES_INT)) return
    do t = 1, mesh%ntri
      cl = p2_dofs(mesh, t)
      cz(:, t) = rmat%col(rmat%rowptr(cl))
    end do
    call csr_pattern_from_cliques(rmat%n, cz, kz, st)
    if (.not. is_ok(st)) return
    deallocate (cz)
    kz%val = 0.0_dp
    do t = 1, mesh%ntri
      cl = p2_dofs(mesh, t)
      call p2_element_stiffness(mesh%xy(:, mesh%tri(:, t)), ke)
      do j = 1, 6
        do q = rmat%rowptr(cl(j)), rmat%rowptr(cl(j) + 1) - 1
          do i = 1, 6
            w = ke(i, j) * rmat%val(q)
            do p = rmat%rowptr(cl(i)), rmat%rowptr(cl(i) + 1) - 1
              do r = kz%rowptr(rmat%col(p)), kz%rowptr(rmat%col(p) + 1) - 1
                if (kz%col(r) == rmat%col(q)) then
                  kz%val(r) = kz%val(r) + rmat%val(p) * w
                  exit
                end if
              end do
            end do
          end do
        end do
      end do
    end do
  end subroutine stream_reduced_stiffness

  !> The Gamma_a edges in boundary order (stream_gamma_rows_t), each chain of consecutive Gamma_a
  !> edges from its first edge on.
  subroutine stream_gamma_a_rows(mesh, is_gamma_a, rows, st)
    type(mesh_t), intent(in) :: mesh
    logical, intent(in) :: is_gamma_a(:)
    type(stream_gamma_rows_t), intent(out) :: rows
    type(status_t), intent(out) :: st
    integer :: l, i0, nl, i, j, jp, e, k, ist
    rows%n = count(is_gamma_a)
    allocate (rows%a(rows%n), rows%b(rows%n), rows%m(rows%n), rows%dof(2, rows%n), rows%prev(rows%n), &
              rows%len(rows%n), rows%bedge(rows%n), stat=ist)
    if (alloc_failed(ist, st, 'the Gamma_a rows', 8_i8 * rows%n, BYTES_INT)) return
    k = 0
    do l = 1, mesh%nloop
      i0 = mesh%loop_start(l)
      nl = mesh%loop_start(l + 1) - i0
      ! start after an edge off Gamma_a, so that every chain is met from its first edge
      jp = 0
      do i = 0, nl - 1
        if (.not. is_gamma_a(mesh%loop_bedge(i0 + i))) jp = i
      end do
      do i = 1, nl
        j = mesh%loop_bedge(i0 + mod(jp + i, nl))
        if (.not. is_gamma_a(j)) cycle
        k = k + 1
        e = mesh%bedge_edge(j)
        rows%a(k) = mesh%bedge_nodes(1, j)
        rows%b(k) = mesh%bedge_nodes(2, j)
        rows%m(k) = mesh%nnode + e
        rows%len(k) = mesh%bedge_length(j)
        rows%dof(1, k) = 2 * (e - 1) + merge(1, 2, rows%a(k) == mesh%edge_nodes(1, e))
        rows%dof(2, k) = 2 * (e - 1) + merge(1, 2, rows%b(k) == mesh%edge_nodes(1, e))
        rows%prev(k) = 0
        rows%bedge(k) = j
        if (i > 1 .and. is_gamma_a(mesh%loop_bedge(i0 + mod(jp + i - 1, nl)))) rows%prev(k) = k - 1
      end do
    end do
  end subroutine stream_gamma_a_rows

  !> The change of basis psi = R z for the active rows (module header): R (n2 x nz), the
  !> prolongation pz (nz x nnode) from the P1 values of the mesh (a vertex unknown takes its
  !> vertex's value, a midpoint the mean of its edge's ends), node_of_z(nz) the P2 node that
  !> carries unknown z (a merged run: its representative vertex).
  subroutine stream_reduced_basis(mesh, rows, active, rmat, pz, node_of_z, st)
    type(mesh_t), intent(in) :: mesh
    type(stream_gamma_rows_t), intent(in) :: rows
    logical, intent(in) :: active(:,:)
    type(rect_t), intent(out) :: rmat
    type(rect_t), intent(out), optional :: pz   !! (stream_p1_prolongation: built when needed)
    integer, allocatable, intent(out) :: node_of_z(:)
    type(status_t), intent(inout) :: st
    integer, allocatable :: rep(:), zof(:)
    integer :: n2, k, i, nz, q, ist
    n2 = mesh%nnode + mesh%nedge
    allocate (rep(mesh%nnode), zof(n2), stat=ist)
    if (alloc_failed(ist, st, 'the reduced basis', int(mesh%nnode, i8) + n2, BYTES_INT)) return
    rep = [(i, i = 1, mesh%nnode)]
    do k = 1, rows%n                       ! both rows active: a and b carry one value
      if (all(active(:, k))) call merge_sets(rep, rows%a(k), rows%b(k))
    end do
    do i = 1, mesh%nnode
      rep(i) = find_root(rep, i)
    end do
    zof = 1
    do i = 1, mesh%nnode
      if (rep(i) /= i) zof(i) = 0
    end do
    do k = 1, rows%n
      if (any(active(:, k))) zof(rows%m(k)) = 0
    end do
    nz = 0
    do i = 1, n2
      if (zof(i) == 0) cycle
      nz = nz + 1
      zof(i) = nz
    end do
    allocate (node_of_z(nz), rmat%rowptr(n2 + 1), stat=ist)
    if (alloc_failed(ist, st, 'the reduced basis', int(nz, i8) + n2 + 1, BYTES_INT)) return
    ! R row by row: a vertex the unknown of its run's representative, a midpoint its own or,
    ! on an active Gamma_a edge, one or two of its ends' (the columns of a row sorted)
    rmat%m = n2
    rmat%n = nz
    rmat%rowptr(1) = 1
    rmat%rowptr(2:) = 1
    do k = 1, rows%n
      if (any(active(:, k))) rmat%rowptr(rows%m(k) + 1) = merge(1, 2, one_entry(k))
    end do
    do i = 1, n2
      rmat%rowptr(i + 1) = rmat%rowptr(i + 1) + rmat%rowptr(i)
    end do
    allocate (rmat%col(rmat%rowptr(n2 + 1) - 1), rmat%val(rmat%rowptr(n2 + 1) - 1), stat=ist)
    if (alloc_failed(ist, st, 'the reduced basis', 3_i8 * (rmat%rowptr(n2 + 1) - 1), BYTES_INT)) return
    rmat%val = 1.0_dp
    do i = 1, n2
      if (zof(i) > 0) node_of_z(zof(i)) = i
      if (i <= mesh%nnode) rmat%col(rmat%rowptr(i)) = zof(rep(i))
      if (i > mesh%nnode .and. zof(i) > 0) rmat%col(rmat%rowptr(i)) = zof(i)
    end do
    do k = 1, rows%n
      if (.not. any(active(:, k))) cycle
      q = rmat%rowptr(rows%m(k))
      associate (za => zof(rep(rows%a(k))), zb => zof(rep(rows%b(k))))
        if (one_entry(k)) then
          rmat%col(q) = za
        else if (active(1, k)) then       ! c_1 = 0: psi_m = (3 psi_a + psi_b) / 4
          call set_pair(q, za, 0.75_dp, zb, 0.25_dp)
        else                              ! c_2 = 0: psi_m = (psi_a + 3 psi_b) / 4
          call set_pair(q, za, 0.25_dp, zb, 0.75_dp)
        end if
      end associate
    end do
    deallocate (rep, zof)
    if (present(pz)) call stream_p1_prolongation(mesh, node_of_z, pz, st)
  contains
    !> The midpoint row of active Gamma_a edge k has one entry: the edge is one value.
    logical function one_entry(k)
      integer, intent(in) :: k
      one_entry = all(active(:, k)) .or. zof(rep(rows%a(k))) == zof(rep(rows%b(k)))
    end function one_entry
    !> Row entries q, q+1: (ca, wa) and (cb, wb), by column.
    subroutine set_pair(q, ca, wa, cb, wb)
      integer, intent(in) :: q, ca, cb
      real(dp), intent(in) :: wa, wb
      if (ca < cb) then
        rmat%col(q:q + 1) = [ca, cb]
        rmat%val(q:q + 1) = [wa, wb]
      else
        rmat%col(q:q + 1) = [cb, ca]
        rmat%val(q:q + 1) = [wb, wa]
      end if
    end subroutine set_pair
  end subroutine stream_reduced_basis

  !> pz (nz x nnode): the unknowns z from the P1 values of the mesh, a vertex unknown its
  !> vertex's value, a midpoint the mean of its edge's ends (node_of_z of
  !> stream_reduced_basis).  st: DS_ERR_MEMORY.
  subroutine stream_p1_prolongation(mesh, node_of_z, pz, st)
    type(mesh_t), intent(in) :: mesh
    integer, intent(in) :: node_of_z(:)
    type(rect_t), intent(out) :: pz
    type(status_t), intent(inout) :: st
    type(triplets_t) :: tr
    integer :: k, i, e, nz, ist
    nz = size(node_of_z)
    allocate (tr%r(2 * nz), tr%c(2 * nz), tr%v(2 * nz), stat=ist)     ! at most two entries a row
    if (alloc_failed(ist, st, 'the prolongation of the stream function', 6_i8 * nz, BYTES_INT)) return
    do k = 1, nz
      i = node_of_z(k)
      if (i <= mesh%nnode) then
        call triplet_add(tr, k, i, 1.0_dp)
      else
        e = i - mesh%nnode
        call triplet_add(tr, k, mesh%edge_nodes(1, e), 0.5_dp)
        call triplet_add(tr, k, mesh%edge_nodes(2, e), 0.5_dp)
      end if
    end do
    call rect_from_triplets(nz, mesh%nnode, tr%r(1:tr%n), tr%c(1:tr%n), tr%v(1:tr%n), pz, st)
  end subroutine stream_p1_prolongation

  !> Appends the entry (row, col, val) to the triplet list tr (its arrays large enough).
  pure subroutine triplet_add(tr, row, col, val)
    type(triplets_t), intent(inout) :: tr
    integer, intent(in) :: row, col
    real(dp), intent(in) :: val
    tr%n = tr%n + 1
    tr%r(tr%n) = row
    tr%c(tr%n) = col
    tr%v(tr%n) = val
  end subroutine triplet_add

  !> Union of the sets of i and j (rep: parent links, roots point to themselves).
  pure subroutine merge_sets(rep, i, j)
    integer, intent(inout) :: rep(:)
    integer, intent(in) :: i, j
    integer :: ri, rj
    ri = find_root(rep, i)
    rj = find_root(rep, j)
    if (ri < rj) rep(rj) = ri
    if (rj < ri) rep(ri) = rj
  end subroutine merge_sets

  pure integer function find_root(rep, i) result(r)
    integer, intent(in) :: rep(:), i
    r = i
    do while (rep(r) /= r)
      r = rep(r)
    end do
  end function find_root

  !> The multipliers mu >= 0 of the active rows from r = K psi - F = C_A^T mu, along each
  !> chain from its first edge: at the midpoint m of edge k, r_m = 4 (mu_1 - mu_2) / L; at
  !> its first end a, r_a = (-3 mu_1 + mu_2) / L + (-mu_1' + 3 mu_2') / L' of the previous
  !> edge (known).  One active row: the midpoint equation; both: both equations.  Inactive
  !> rows get 0.
  pure subroutine mu_of_chains(rows, active, r, mu)
    type(stream_gamma_rows_t), intent(in) :: rows
    logical, intent(in) :: active(:,:)
    real(dp), intent(in) :: r(:)
    real(dp), intent(out) :: mu(:,:)
    real(dp) :: rho, delta, l
    integer :: k, kp
    mu = 0.0_dp
    do k = 1, rows%n
      l = rows%len(k)
      delta = r(rows%m(k)) * l / 4
      if (all(active(:, k))) then
        rho = r(rows%a(k))
        kp = rows%prev(k)
        if (kp > 0) rho = rho - (-mu(1, kp) + 3 * mu(2, kp)) / rows%len(kp)
        mu(2, k) = -(rho * l + 3 * delta) / 2
        mu(1, k) = mu(2, k) + delta
      else if (active(1, k)) then
        mu(1, k) = delta
      else if (active(2, k)) then
        mu(2, k) = -delta
      end if
    end do
  end subroutine mu_of_chains

  !> The next active set of the primal-dual active set method: an active row stays while
  !> its multiplier is not negative, a free row joins when its flux is negative (tolerances
  !> relative to the largest multiplier and flux, see release_tol).
  pure subroutine next_active(rows, active, mu, x, release, violation, next)
    type(stream_gamma_rows_t), intent(in) :: rows
    logical, intent(in) :: active(:,:)
    real(dp), intent(in) :: mu(:,:), x(:)
    real(dp), intent(in) :: release, violation
    logical, intent(out) :: next(:,:)
    real(dp) :: mu_scale, x_scale
    integer :: k, i
    mu_scale = 0.0_dp
    if (size(mu) > 0) mu_scale = maxval(abs(mu))
    x_scale = maxval(abs(x))
    do k = 1, rows%n
      do i = 1, 2
        if (active(i, k)) then
          next(i, k) = mu(i, k) >= -release * mu_scale
        else
          next(i, k) = x(rows%dof(i, k)) < -violation * x_scale
        end if
      end do
    end do
  end subroutine next_active

  !> Make psi feasible without leaving the curl fields: along each chain of Gamma_a edges,
  !> in boundary order, psi_b is raised to psi_a where it fell below, then psi_m is moved into
  !> [(3 psi_a + psi_b) / 4, (psi_a + 3 psi_b) / 4]: both rows of every edge are then >= 0,
  !> and q = curl psi stays divergence-free (clipping the fluxes instead would break the
  !> divergence and leave the equilibration to carry the defect to Gamma_u).  Changes only
  !> the values of the rows the solve left violated.
  pure subroutine make_monotone(rows, psi)
    type(stream_gamma_rows_t), intent(in) :: rows
    real(dp), intent(inout) :: psi(:)
    integer :: k
    do k = 1, rows%n
      associate (pa => psi(rows%a(k)), pb => psi(rows%b(k)), pm => psi(rows%m(k)))
        pb = max(pb, pa)
        pm = min(max(pm, (3 * pa + pb) / 4), (pa + 3 * pb) / 4)
      end associate
    end do
  end subroutine make_monotone
end module dualsig_dual_p2_stream
