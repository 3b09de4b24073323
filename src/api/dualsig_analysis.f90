!> The analysis pipeline: problem -> mesh levels -> primal solve -> dual solve -> bounds.
!>
!> One implementation behind every front end (the namelist driver, DSSIGN, the bench and
!> the stress programs).  A caller describes the problem (`analysis_problem_t`: kind, coarse
!> mesh, Gamma_u/Gamma_a markers, load, optional exact solution) and the run
!> (`analysis_settings_t`), starts an analysis (`analysis_start`) and asks for one level at
!> a time (`analysis_next_level`): the first call solves on the coarse mesh, every later
!> call refines uniformly, carries the solution over (grid sequencing) and solves again.
!> Each level returns a `level_result_t` (sizes, iterations, factorisations, timings, the
!> bounds with their element indicators, the exact errors when u is known, the fields on
!> request, and the warnings of the level).  Nothing is printed or written here.
!>
!> Guarantees as in the paper: for P1 est = E(q_h, u_h) of (6.13) >= ||u - u_h||_1^2 and
!> energy_lo <= (f, u) <= energy_hi (6.14); for P2 est = E(lambda_h, u_h) of (6.26) >=
!> |u - u_h|_1^2 and the bracket of Theorem 6.4, provided the dual field is admissible
!> (`certified`: for P2 its divergence defect is at most `admissible_defect`).
module dualsig_analysis
  use dualsig_kinds, only: dp
  use dualsig_clock, only: wall_seconds
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use dualsig_status, only: status_t, set_error, is_ok, is_warning, is_error, DS_OK, DS_ERR_INPUT, DS_WARN_NOT_CONVERGED, &
                            DS_WARN_NOT_CERTIFIED, DS_ERR_NUMERIC, DS_ERR_LAPACK, DS_ERR_MEMORY, set_warning
  use dualsig_strings, only: itoa, rtoa
  use dualsig_problem_kinds, only: PROBLEM_P1, PROBLEM_P2
  use dualsig_exact_boundary, only: exact_boundary_check
  use dualsig_mesh, only: mesh_t, mesh_h, mesh_diameter, mesh_move, mesh_release_adjacency, mesh_triangle_area, &
                          mesh_longest_side, mesh_coordinate_scale, &
                          mesh_ensure_adjacency, mesh_boundary_markers
  use dualsig_mesh_check, only: mesh_check_geometry
  use dualsig_mesh_refine, only: mesh_refine_uniform, mesh_prolongate_p1
  use dualsig_mesh_adapt, only: mesh_refine_marked, mesh_prolongate_bisection, mesh_mark_doerfler, &
                                mesh_bisection_origin, mesh_bisection_ancestor
  use dualsig_assembly_equilibrium, only: equilibrium_prolongate_bisection
  use dualsig_sparse_direct, only: ORDERING_GEOMETRIC
  use dualsig_ordering_geometric, only: select_ordering
  use dualsig_spectral, only: jacobi_scaled_extremes, sor_omega_from_jacobi
  use dualsig_qp_types, only: BOUND_FIXED, BOUND_LOWER
  use dualsig_solver_psor, only: psor_settings_t, psor_result_t, psor_solve
  use dualsig_solver_active_set, only: active_set_settings_t, active_set_result_t, active_set_solve
  use dualsig_solver_multigrid, only: mg_hierarchy_t, mg_settings_t, mg_result_t, mg_reset, mg_add_level, mg_clear, &
                                      multigrid_solve, mg_build_algebraic, mg_finest_size
  use dualsig_solver_boundary_schur, only: boundary_schur_settings_t, boundary_schur_result_t, boundary_schur_qp_solve, &
                                           boundary_schur_max_default
  use dualsig_fields, only: field_t, vector_field_t
  use dualsig_quadrature, only: tri_rule_t, tri_rule
  use dualsig_dual_p2_field, only: dual_p2_field_t
  use dualsig_problem_primal, only: primal_system_t, primal_constraints, primal_assemble
  use dualsig_problem_dual_p1, only: dual_p1_settings_t, dual_p1_result_t, dual_p1_solve
  use dualsig_problem_dual_p2, only: dual_p2_settings_t, dual_p2_result_t, dual_p2_solve
  use dualsig_dual_p2_stream, only: stream_prolongate, stream_prolongate_set, stream_prolongate_bisection, &
                                    stream_prolongate_set_bisection
  use dualsig_problem_dual_hdiv, only: dual_hdiv_solve, hdiv_nested_t, dual_hdiv_nested_refine, dual_hdiv_nested_free
  use dualsig_estimate_dual_hdiv, only: dual_hdiv_bounds_load, dual_hdiv_errors
  use dualsig_estimate_errors, only: p1_error_norms
  use dualsig_estimate_dual_p1, only: dual_p1_bounds_t, dual_p1_bounds_load, dual_p1_errors
  use dualsig_load_data, only: load_data_t, load_data_build, load_data_move
  use dualsig_estimate_dual_p2, only: dual_p2_bounds_t, dual_p2_bounds, dual_p2_bounds_load, dual_p2_error
  use dualsig_alloc, only: alloc_failed, BYTES_LOGICAL, BYTES_REAL, BYTES_INT
  implicit none
  private

  public :: analysis_problem_t, analysis_settings_t, level_result_t, analysis_t
  public :: analysis_start, analysis_next_level, analysis_free
  public :: load_degree, exact_degree, bound_degree_p1, bound_degree_p2, max_level_warnings
  public :: dual_spaces, mg_auto_min_unknowns
  public :: analysis_progress
  public :: adapt_settings_t, analysis_next_step, analysis_adapt_stop, adapt_stop_text, certified_rel_error
  public :: analysis_aim_growth, adapt_aim_growth, adapt_aim_margin, adapt_aim_rate_max, analysis_limit_growth
  public :: adapt_min_growth_default, adapt_min_growth_max
  public :: ADAPT_GOING, ADAPT_STOP_TOL, ADAPT_STOP_NDOF, ADAPT_STOP_SECONDS, ADAPT_STOP_STEPS, adapt_max_steps

  !> Degree of the quadrature of the load vectors (>= 5 as required; Radon's rule).
  integer, parameter :: load_degree = 5
  !> Degree of the quadrature of integrals of the exact solution.
  integer, parameter :: exact_degree = 16
  !> Degree of the quadrature of the P1 bounds (6.13), (6.14).
  integer, parameter :: bound_degree_p1 = 16
  !> Degree of the quadrature of the P2 bounds (lambda^h is not a polynomial; each point
  !> costs a line integral of f).
  integer, parameter :: bound_degree_p2 = 12
  !> Lanczos settings of the automatic SOR parameter.
  integer, parameter :: lanczos_max_steps = 400
  !> 'auto' runs multigrid above this many unknowns when a hierarchy exists (below it the
  !> factorisation of the warm-started active set costs about as much as the V-cycles)
  integer, parameter :: mg_auto_min_unknowns = 10000
  !> Gauss-Seidel sweeps the P2 dual's stream function may take on the last level of a uniform
  !> run before it builds the multigrid (dual_p2_settings_t%smooth_sweeps): 8 reach the
  !> algebraic share 10^-3 at levels 8 and 9 of p2_contact; where they would not (the
  !> previous level left a smooth error above the share, e.g. at a corner singularity) they
  !> give up early and the V-cycles go on from the swept psi (dualsig_dual_p2_stream)
  integer, parameter :: p2_last_sweeps = 10
  real(dp), parameter :: lanczos_rel_tol = 1.0e-3_dp
  !> The dual spaces of P1: 'hdiv' (Raviart-Thomas of order 1, div q piecewise linear; the
  !> default) and 'paper' (continuous piecewise-linear vector fields, Section 3).
  character(len=*), parameter :: dual_spaces = 'hdiv, paper'
  !> Warnings a level can carry (primal limit, dual limit, dual not admissible).
  integer, parameter :: max_level_warnings = 3

  !> Smallest est and energy_hi that are certified (check_representable_bounds): below it an
  !> error of relative size epsilon is below the smallest normal number.
  real(dp), parameter :: representable_floor = tiny(1.0_dp) / epsilon(1.0_dp)
  !> check_exact_solution: a certified level whose error against u_exact exceeds the
  !> guaranteed bound, err^2 > (1 + exact_consistency_tol) est, refutes u_exact.  The margin
  !> covers the quadrature of err (u_exact is not a polynomial; est needs no margin).
  real(dp), parameter :: exact_consistency_tol = 1.0e-2_dp
  !> Roundings allowed per term of the sums of the energy bounds (a term is a product of a
  !> few factors summed over at most the points of one quadrature rule) in their rounding
  !> allowance, widen_for_rounding.
  integer, parameter :: rounding_ops_per_term = 64
  !> explain_small_p1_domain: a P1 domain of smaller diameter may fail for its scale.
  real(dp), parameter :: p1_small_domain = 1.0e-3_dp
  !> explain_small_p1_domain: a failure on triangles of aspect ratio (longest side^2 over
  !> twice the area) above this is put down to them.
  real(dp), parameter :: p1_stretched = 1.0e6_dp
  !> A lower energy bound below this fraction of the upper one is no lower bound for the
  !> certified relative error sqrt(est / energy_lo): it is at the rounding level of the
  !> energy (u_h = 0 on a coarse mesh gives 1e-47 against 10), and the quotient (1e24) is a
  !> valid but meaningless bound; the column is left empty instead.
  real(dp), parameter :: energy_lo_rel_floor = 1.0e-12_dp
  !> Why an adaptive loop stops (analysis_adapt_stop): not yet; the certified relative error
  !> reached tol; max_ndof unknowns reached; the next step would end after max_seconds; the
  !> largest number of steps (adapt_max_steps, the two digits of the .vtu names).
  integer, parameter :: ADAPT_GOING = 0, ADAPT_STOP_TOL = 1, ADAPT_STOP_NDOF = 2, ADAPT_STOP_SECONDS = 3, &
                        ADAPT_STOP_STEPS = 4
  integer, parameter :: adapt_max_steps = 99
  !> A triangle whose longest side is at most this times eps times the coordinate scale
  !> (mesh_coordinate_scale) is not marked: below it a bisection's midpoint is known to
  !> less than about 1e-6 of the side.  Above it every child of a bisection meets the
  !> zero-area test (mesh_zero_area is relative to each triangle, and newest-vertex
  !> bisection keeps the shapes of the coarse mesh).
  real(dp), parameter :: adapt_side_floor = 1.0e6_dp
  !> The step that should reach tol aims at it (analysis_aim_growth): the unknowns the
  !> observed rate p of sqrt(est) ~ ndof^(-p) asks for, times adapt_aim_margin (a step
  !> short of tol costs a whole further step, one past it only its excess); p is taken at
  !> most adapt_aim_rate_max (the optimal rate of P1 elements in 2D, so a faster
  !> pre-asymptotic decay does not shorten the step), and below adapt_aim_rate_min the
  !> prediction is not used.  The refinement is redone at most adapt_aim_tries times with
  !> fewer marks (scaled by the ratio of allowed to obtained new nodes, times
  !> adapt_aim_shrink) until its new nodes stay within the aim.
  real(dp), parameter :: adapt_aim_margin = 1.1_dp
  real(dp), parameter :: adapt_aim_rate_max = 0.5_dp
  real(dp), parameter :: adapt_aim_rate_min = 0.1_dp
  real(dp), parameter :: adapt_aim_shrink = 0.98_dp
  integer, parameter :: adapt_aim_tries = 5
  !> After adapt_aim_tries proportional corrections a step still above its aim halves its
  !> marks until it is within (at most this many times): the memory check counted the aim.
  integer, parameter :: adapt_aim_halvings = 30
  !> Growths beyond this are not aims (a bisection step at most doubles the triangles).
  real(dp), parameter :: adapt_aim_growth_max = 2.0_dp
  !> Default of adapt_settings_t%min_growth: every step adds at least this fraction of the
  !> unknowns less one (the largest indicators beyond Doerfler's set).  A loop whose steps
  !> grow the unknowns by g costs about g / (g - 1) times its last step: 3.9 at Doerfler's
  !> 1.34 (theta = 0.5 on the L-shapes), 3 at 1.5.  The optimal-rate theory of Doerfler
  !> marking asks for a set within a constant factor of the minimal one: so it is while
  !> Doerfler's set itself grows the unknowns by a fixed fraction (1.33-1.52 on the three
  !> work-precision cases, whose rates stay 0.50; doc/performance.md).
  real(dp), parameter :: adapt_min_growth_default = 1.5_dp
  !> Largest min_growth: marking every triangle once adds about one node per two triangles,
  !> i.e. about doubles the unknowns.
  real(dp), parameter :: adapt_min_growth_max = 2.0_dp
  !> Default of adapt_settings_t%algebraic_share.  est(u_h, lambda) bounds the error for any
  !> admissible lambda, so a step's dual solve need only be accurate enough not to raise est
  !> by more than this share of it: sqrt(est) by at most half of it (0.05 %).  The stream
  !> function's CG then stops after a few iterations instead of at its residual tolerance
  !> (doc/performance.md); the bound stays guaranteed whatever the share.  The primal is
  !> always solved to its tolerance: u_h is the answer a user takes away (stopped at the same
  !> share it was an iterate, KKT residual about 1e-4, L2 error up to 1.5 times the
  !> minimiser's on p2_contact from 8e5 to 6.5e6 unknowns), lambda_h the certificate.
  real(dp), parameter :: adapt_algebraic_share_default = 1.0e-3_dp
  !> Default of analysis_settings_t%dual_algebraic_share, the same share for the levels of a
  !> uniform run: the dual's bound moves by at most about share/2 relative (sqrt(1 + share)),
  !> 1.0000640 -> 1.0000739 in eff at level 9 of p2_contact, for 2 instead of 5 V-cycles.
  real(dp), parameter :: dual_algebraic_share_default = 1.0e-3_dp

  !> The adaptive loop solve -> estimate -> mark (Doerfler) -> refine (newest-vertex
  !> bisection): analysis_next_step, analysis_adapt_stop.
  type :: adapt_settings_t
    logical :: enabled = .false.
    real(dp) :: theta = 0.5_dp          !! Doerfler parameter: mark sum_M eta_T^2 >= theta est
    real(dp) :: tol = 0.0_dp            !! target of sqrt(est / energy_lo) (certified steps only); 0 = none
    integer :: max_ndof = 0             !! stop at a step with at least this many unknowns; 0 = no limit
    real(dp) :: max_seconds = 0.0_dp    !! stop before a step predicted to end later; 0 = no limit
    integer :: max_steps = adapt_max_steps !! at most this many steps (<= adapt_max_steps)
    !> each step at least this growth of the unknowns (1 <= min_growth <= adapt_min_growth_max;
    !> 1: Doerfler's set alone), unless it aims at tol (analysis_aim_growth)
    real(dp) :: min_growth = adapt_min_growth_default
    !> the share of est the algebraic error of a step's dual solve may add (0 <= share < 1; 0:
    !> solved to its solver's tolerance), predicted from the previous step (algebraic_est_tol)
    real(dp) :: algebraic_share = adapt_algebraic_share_default
  end type adapt_settings_t

  !> The progress callback of the pipeline (analysis_settings_t%progress), for a front end
  !> that reports long phases (the library itself never prints): called when a phase of
  !> level (or adaptive step) `level` starts (finished = .false., seconds = 0) and when it
  !> ends (finished = .true., seconds = its wall time).  The phases, in order: 'refine'
  !> (from level 2 on: refinement and transfer of u_h), 'assemble' (geometry checks,
  !> matrices, constraints), 'primal solve', 'dual analysis' (dual solve and bounds).  A
  !> phase that fails gets no end call.
  abstract interface
    subroutine analysis_progress(level, phase, finished, seconds)
      import :: dp
      integer, intent(in) :: level
      character(len=*), intent(in) :: phase
      logical, intent(in) :: finished
      real(dp), intent(in) :: seconds
    end subroutine analysis_progress
  end interface

  !> What is solved: the problem, its coarse mesh, boundary parts and data.
  type :: analysis_problem_t
    integer :: kind = PROBLEM_P2                     !! PROBLEM_P1 or PROBLEM_P2
    type(mesh_t) :: mesh                             !! coarse mesh, topology built, counter-clockwise
    integer, allocatable :: gamma_u(:)               !! boundary markers of Gamma_u (0 = unused slot; unallocated: none)
    !> boundary markers of Gamma_a (0 = unused slot; unallocated: none for P2, all of Gamma for P1)
    integer, allocatable :: gamma_a(:)
    class(field_t), allocatable :: f                 !! the load
    !> abscissae x = c where f has a kink (integrals are split there); left unallocated the
    !> integrals are not split at all
    real(dp), allocatable :: x_breaks(:)
    class(field_t), allocatable :: u_exact           !! exact solution, for verification (optional)
    class(vector_field_t), allocatable :: grad_exact !! its gradient (with u_exact)
  end type analysis_problem_t

  !> How it is solved.  Defaults are the namelist driver's.
  type :: analysis_settings_t
    integer :: levels = 1                         !! levels of uniform refinement, the coarse mesh is level 1
    logical :: nested = .true.                    !! start each level from the prolongated solution
    !> primal solver: 'auto' (the default: 'schur' when at most max_schur unknowns are
    !> bounded, else 'active_set'), 'schur' (one factorisation with the bounded unknowns
    !> eliminated last, the exact dense QP on their Schur complement), 'active_set'
    !> (primal-dual active set, bordered changes), 'psor' or 'multigrid' (truncated nonsmooth
    !> Newton multigrid on the hierarchy of uniform refinements; 'auto' on level 1, which has none)
    character(len=16) :: method = 'auto'
    integer :: max_schur = boundary_schur_max_default  !! 'auto': most bounded unknowns for 'schur'
    real(dp) :: omega = 1.0_dp                    !! psor: relaxation
    logical :: omega_auto = .false.               !! psor: omega from a Lanczos estimate per level
    real(dp) :: tol = 1.0e-10_dp                  !! psor: relative KKT tolerance
    integer :: max_iter = 200000                  !! psor sweeps / active-set changes
    integer :: check_every = 10                   !! psor: sweeps between residuals
    !> every CHOLMOD factorisation (ORDERING_* of dualsig_sparse_direct); the default, as the
    !> batch driver's `nd`: geometric nested dissection from the points of the unknowns (AMD
    !> below 1e4 unknowns)
    integer :: ordering = ORDERING_GEOMETRIC
    logical :: dual = .true.                      !! dual analysis
    logical :: bounds = .true.                    !! with dual: the bounds from the dual field (off: the field only)
    !> keep the multigrid hierarchy (an%mg, with its coarsest factor) and the nested dual's state
    !> after the last level, for a caller that uses them (then analysis_free releases them)
    logical :: keep_hierarchy = .false.
    !> P1: active_set | uzawa | nested (hdiv, from level 2 on); P2: augmented | multigrid | uzawa;
    !> default: P1 nested (hdiv) or active_set (paper), P2 multigrid where the primal's grid
    !> hierarchy reaches the level (p2_dual_choice), else augmented
    character(len=16) :: dual_method = 'default'
    real(dp) :: dual_rho = 0.0_dp                 !! Uzawa step, 0 = automatic
    real(dp) :: dual_tol = 1.0e-10_dp             !! Uzawa tolerance, floor
    real(dp) :: dual_tol_h2 = 1.0e-4_dp           !! Uzawa tolerance: max(dual_tol, dual_tol_h2 (h/diam)^2)
    integer :: dual_max_iter = 20000              !! dual iterations
    real(dp) :: dual_penalty = 0.0_dp             !! P2 augmented Lagrangian r, 0 = automatic
    character(len=16) :: dual_inner = 'schur'     !! P2 augmented: inner solver, 'schur' or 'active_set'
    !> P2: the particular field lambda^f, 'polynomial' (every bound integral exact, f - f_T an
    !> oscillation term) or 'stream' (the paper's lambda_bar + curl omega)
    character(len=16) :: dual_particular = 'polynomial'
    !> the share of est the iterative P2 dual solve (the stream function) of a level of a
    !> uniform run (from level 2 on) may leave, predicted from the last level (algebraic_est_tol);
    !> 0: solved to the solver's tolerance.  Adaptive steps take adapt%algebraic_share.
    real(dp) :: dual_algebraic_share = dual_algebraic_share_default
    !> P1: the dual space, 'hdiv' (RT1, tight bounds) or 'paper' (the [V_h]^2 of Section 3); P2 ignores it
    character(len=16) :: dual_space = 'hdiv'
    !> Largest relative divergence defect of the P2 dual field for which est is certified.
    real(dp) :: admissible_defect = 1.0e-10_dp
    logical :: keep_fields = .false.              !! return the dual field in the level result
    type(adapt_settings_t) :: adapt               !! the adaptive loop (analysis_next_step)
    !> called at the start and end of each phase of a level (analysis_progress); none by default
    procedure(analysis_progress), pointer, nopass :: progress => null()
  end type analysis_settings_t

  !> What one level produced.  Columns not computed keep their defaults (has_* false).
  type :: level_result_t
    integer :: level = 0
    integer :: nnode = 0, ntri = 0
    integer :: ndof = 0                     !! unknowns not fixed by Gamma_u
    real(dp) :: h = 0.0_dp                  !! longest side
    ! primal
    !> the primal solver used: 'schur', 'active_set', 'psor', 'multigrid' or 'multigrid_amg'
    character(len=16) :: primal_method = ''
    integer :: primal_iters = 0             !! sweeps, active-set iterations, dense pivoting steps ('schur'), V-cycles
    integer :: primal_factorisations = 0    !! active set, schur: CHOLMOD factorisations; multigrid: Galerkin updates
    integer :: primal_bordered = 0          !! active set: iterations done by bordering on the kept factor
    real(dp) :: primal_seconds = 0.0_dp     !! wall time of the solve
    real(dp) :: kkt_residual = 0.0_dp
    logical :: primal_limit = .false.       !! the primal solver stopped at its iteration limit
    real(dp), allocatable :: u(:)           !! u_h at the nodes
    integer, allocatable :: bound_kind(:)   !! BOUND_* per node (dualsig_qp_types)
    real(dp), allocatable :: bound(:)       !! bound value per node
    ! exact errors (has_exact)
    logical :: has_exact = .false.
    real(dp) :: err_energy = 0.0_dp         !! energy norm of u - u_h: ||.||_1 (P1), |.|_1 (P2)
    real(dp) :: err_l2 = 0.0_dp
    !> the level's bound refuted u_exact (check_exact_solution): the error columns of every
    !> level are meaningless, and the level ends with DS_ERR_INPUT
    logical :: exact_refuted = .false.
    ! dual analysis (has_dual)
    logical :: has_dual = .false.
    character(len=16) :: dual_method = ''
    character(len=16) :: dual_space = ''    !! P1: 'hdiv' or 'paper'
    logical :: dual_limit = .false.         !! the dual solver stopped at its iteration limit
    integer :: dual_iters = 0
    real(dp) :: dual_seconds = 0.0_dp
    real(dp) :: est = 0.0_dp                !! the bound of the squared energy error: E of (6.13) / (6.26), P1 hdiv: min(E, est_pw)
    real(dp) :: est_hypercircle = 0.0_dp    !! P1: E(q, u~) of (6.13) = F(q) - energy_lo, also the bound (6.18); P2: est
    real(dp) :: energy_lo = 0.0_dp, energy_hi = 0.0_dp
    real(dp), allocatable :: est_elem(:)    !! element contributions to est (sum = est)
    logical :: certified = .false.          !! est and energy_hi are guaranteed bounds
    integer :: load_unresolved = 0          !! triangles where the load's integrals did not converge
    real(dp) :: oscillation = 0.0_dp        !! P2: (sum_T ((h_T/pi) ||f - Pi_1 f||_T)^2)^(1/2), part of est
    real(dp) :: err_q = 0.0_dp              !! with has_exact: P1 ||q - grad u||, P2 ||grad u - lambda_h||
    real(dp) :: err_div = 0.0_dp            !! with has_exact, P1: ||f + div q - u||
    real(dp) :: err_q_norm = 0.0_dp         !! with has_exact, P1: (err_q^2 + err_div^2)^(1/2)
    type(dual_p1_result_t) :: dual_p1       !! solver report (P1)
    type(dual_p2_result_t) :: dual_p2       !! solver report (P2)
    real(dp), allocatable :: q(:)           !! keep_fields, P1 'paper': q_h at the nodes, (2, nnode) flattened
    real(dp), allocatable :: q_hdiv(:)      !! keep_fields, P1 'hdiv': the RT1 unknowns (dualsig_assembly_dual_hdiv)
    type(dual_p2_field_t) :: lambda         !! keep_fields, P2: lambda_h
    ! timings of the pipeline (all levels) and of the adaptive loop (analysis_next_step)
    real(dp) :: estimate_seconds = 0.0_dp   !! wall time of the dual part: load data, dual solve, bounds
    !> wall time of the comparisons with the exact solution (primal and dual errors), not in
    !> estimate_seconds: a check of the code, which a user's own problem does not pay
    real(dp) :: verify_seconds = 0.0_dp
    real(dp) :: refine_seconds = 0.0_dp     !! wall time of marking, refining and transferring u
    real(dp) :: step_seconds = 0.0_dp       !! wall time of the whole level / step
    real(dp) :: elapsed_seconds = 0.0_dp    !! wall time since analysis_start
    integer :: nmarked = 0                  !! adaptive: triangles marked on the previous step
    !> adaptive: the growth of the unknowns this step aimed at to reach tol
    !> (analysis_aim_growth; 0: Doerfler's set as it is)
    real(dp) :: aim_growth = 0.0_dp
    integer :: nheld = 0                    !! adaptive: triangles not marked: at the size floor (adapt_side_floor)
    integer :: max_depth = 0                !! adaptive: most bisections from a coarse triangle
    ! warnings of this level (codes DS_WARN_*, messages without the level)
    integer :: nwarnings = 0
    type(status_t) :: warnings(max_level_warnings)
  end type level_result_t

  !> The state of an analysis between levels.
  type :: analysis_t
    type(analysis_problem_t) :: problem     !! the problem (its coarse mesh moved to mesh at analysis_start)
    type(analysis_settings_t) :: settings
    type(mesh_t) :: mesh                    !! the mesh of the current level
    integer :: level = 0                    !! levels done
    logical :: started = .false.            !! analysis_start succeeded (analysis_free clears it)
    real(dp), allocatable :: u(:)           !! u_h of the current level
    real(dp), allocatable :: u_start(:)     !! start of level 1 (optional)
    character(len=16) :: dual_method = ''   !! resolved dual method
    real(dp), allocatable :: est_elem(:)    !! the element indicators of the current level (marking)
    !> dual method 'nested': the levels so far and the previous field, prolongated to this level
    type(hdiv_nested_t) :: nest
    !> P2 dual 'multigrid': the last level's stream function, prolongated by a uniform refinement
    real(dp), allocatable :: psi(:)
    integer, allocatable :: psi_set(:,:)     !! and its active set on Gamma_a (2, nbedge)
    !> P2 dual: the last level's polynomial lambda^f (global edge-end fluxes), carried to the
    !> refinement (bisection or uniform): the start of the next lambda^f, so psi stays a close start
    real(dp), allocatable :: flux_f(:)
    real(dp) :: prolong_seconds = 0.0_dp    !! wall time of that prolongation (part of the dual's cost)
    real(dp) :: t_start = 0.0_dp            !! wall clock at analysis_start
    real(dp) :: last_step_seconds = 0.0_dp  !! wall time of the last level / step
    integer :: last_ndof = 0, prev_ndof = 0 !! unknowns of the last two levels / steps
    !> their certified relative errors (certified_rel_error; huge: not certified)
    real(dp) :: last_rel = huge(1.0_dp), prev_rel = huge(1.0_dp)
    real(dp) :: last_est = 0.0_dp           !! est of the last level / step (0: none)
    real(dp) :: new_per_mark = 0.0_dp       !! new nodes per marked triangle of the last bisection (0: none yet)
    !> the largest growth of the unknowns the next adaptive step may take (0: no limit), set
    !> by analysis_limit_growth (the driver's memory check) for that step only
    real(dp) :: growth_limit = 0.0_dp
    type(tri_rule_t) :: load_rule, exact_rule, bound_rule_p1, bound_rule_p2
    type(mg_hierarchy_t) :: mg              !! method 'multigrid': the grids of the uniform refinements so far
    !> adaptive steps: the last step's load data, and per triangle of the refined mesh the
    !> triangle of that step it is (mesh_bisection_origin; 0: new), for level_load_data
    type(load_data_t) :: load_keep
    integer, allocatable :: tri_origin(:)
  end type analysis_t

contains

  !> Check the settings against the problem and prepare the analysis; u_start (optional,
  !> nnode of the coarse mesh) is the start of the first primal solve (zero otherwise).
  subroutine analysis_start(an, problem, settings, st, u_start)
    type(analysis_t), intent(out) :: an
    type(analysis_problem_t), intent(in) :: problem
    type(analysis_settings_t), intent(in) :: settings
    type(status_t), intent(out) :: st
    real(dp), intent(in), optional :: u_start(:)
    character(len=:), allocatable :: method
    integer, allocatable :: kinds(:)
    real(dp), allocatable :: bnds(:)
    if (problem%kind /= PROBLEM_P1 .and. problem%kind /= PROBLEM_P2) then
      call set_error(st, DS_ERR_INPUT, 'analysis: problem kind ' // itoa(problem%kind) // ' (expected 1 = P1 or 2 = P2)')
      return
    end if
    if (.not. allocated(problem%f)) then
      call set_error(st, DS_ERR_INPUT, 'analysis: the problem has no load f')
      return
    end if
    if (.not. (settings%dual_algebraic_share >= 0.0_dp .and. settings%dual_algebraic_share < 1.0_dp)) then
      call set_error(st, DS_ERR_INPUT, 'analysis: dual algebraic_share out of range (expected 0 <= share < 1)')
      return
    end if
    if (settings%adapt%enabled) then
      if (.not. (settings%adapt%theta > 0.0_dp .and. settings%adapt%theta <= 1.0_dp)) then
        call set_error(st, DS_ERR_INPUT, 'analysis: adapt theta out of range (expected 0 < theta <= 1)')
        return
      end if
      if (.not. (settings%adapt%algebraic_share >= 0.0_dp .and. settings%adapt%algebraic_share < 1.0_dp)) then
        call set_error(st, DS_ERR_INPUT, 'analysis: adapt algebraic_share out of range (expected 0 <= share < 1)')
        return
      end if
      if (.not. (settings%adapt%min_growth >= 1.0_dp .and. settings%adapt%min_growth <= adapt_min_growth_max)) then
        call set_error(st, DS_ERR_INPUT, 'analysis: adapt min_growth out of range (expected 1 <= min_growth <= ' // &
          rtoa(adapt_min_growth_max) // ')')
        return
      end if
      if (.not. settings%dual .or. .not. settings%bounds) then
        call set_error(st, DS_ERR_INPUT, 'analysis: adaptive refinement needs the dual analysis with its ' // &
          'bounds (the element indicators of est)')
        return
      end if
      ! tol is met by a certified step only, and this particular field is never certified
      if (settings%adapt%tol > 0.0_dp .and. problem%kind /= PROBLEM_P1 .and. &
          settings%dual_particular == 'stream') then
        call set_error(st, DS_ERR_INPUT, "analysis: &adapt tol needs certified steps, and with &dual particular " // &
          "= 'stream' no step is certified (its bounds rest on quadrature); expected particular = 'polynomial' " // &
          "(the default) or tol = 0 with max_ndof or max_seconds")
        return
      end if
      if (settings%adapt%max_steps < 1 .or. settings%adapt%max_steps > adapt_max_steps) then
        call set_error(st, DS_ERR_INPUT, 'analysis: adapt max_steps = ' // itoa(settings%adapt%max_steps) // &
          ' (expected 1 to ' // itoa(adapt_max_steps) // ')')
        return
      end if
    end if
    if (settings%levels < 1) then
      call set_error(st, DS_ERR_INPUT, 'analysis: levels = ' // itoa(settings%levels) // ' (expected >= 1)')
      return
    end if
    if (.not. any(settings%method == [character(len=16) :: 'auto', 'schur', 'active_set', 'psor', 'multigrid'])) then
      call set_error(st, DS_ERR_INPUT, "analysis: primal method '" // trim(settings%method) // &
        "' (expected 'auto', 'schur', 'active_set', 'psor' or 'multigrid')")
      return
    end if
    method = trim(settings%dual_method)
    if (method == 'default') method = trim(merge('active_set', 'auto      ', problem%kind == PROBLEM_P1))
    ! P1 in RT1: 'nested' (the exact active set on the first level and wherever the previous
    ! level is not a uniform coarsening; from level 2 on the same bound at a fraction of the cost)
    if (settings%dual_method == 'default' .and. problem%kind == PROBLEM_P1 .and. settings%dual_space == 'hdiv') &
      method = 'nested'
    if (settings%dual .and. problem%kind == PROBLEM_P1 .and. method == 'nested' .and. &
        settings%dual_space == 'paper') then
      ! the method applies to P1, not to this space
      call set_error(st, DS_ERR_INPUT, "analysis: dual method 'nested' needs dual space 'hdiv' (its hierarchy " // &
        "is of RT1 fields); with space 'paper' the methods are active_set and uzawa")
      return
    end if
    if (settings%dual) then
      if ((problem%kind == PROBLEM_P1 .and. (method == 'augmented' .or. method == 'multigrid')) .or. &
          (problem%kind /= PROBLEM_P1 .and. (method == 'active_set' .or. method == 'nested'))) then
        call set_error(st, DS_ERR_INPUT, "analysis: dual method '" // method // "' does not apply to problem P" // &
          itoa(problem%kind) // '; P1: active_set, uzawa or nested (space hdiv), P2: augmented, multigrid or uzawa')
        return
      end if
    end if
    if (problem%kind == PROBLEM_P1 .and. settings%dual) then
      if (settings%dual_space /= 'hdiv' .and. settings%dual_space /= 'paper') then
        call set_error(st, DS_ERR_INPUT, "analysis: dual space '" // trim(settings%dual_space) // &
          "' (expected 'hdiv' or 'paper')")
        return
      end if
    end if
    if (allocated(problem%u_exact) .and. allocated(problem%grad_exact) .and. allocated(problem%gamma_u) .and. &
        allocated(problem%gamma_a) .and. allocated(problem%mesh%loop_start) .and. &
        allocated(problem%mesh%bedge_marker)) then
      ! the boundary parts themselves first (the message each level would give), then u_exact on them
      call primal_constraints(problem%mesh, problem%kind, problem%gamma_u, problem%gamma_a, kinds, bnds, st, &
                              every_loop_gamma_u=settings%dual .and. problem%kind /= PROBLEM_P1)
      if (.not. is_ok(st)) return
      call exact_boundary_check(problem%mesh, problem%kind, problem%gamma_u, problem%u_exact, problem%grad_exact, &
                                'analysis: the exact solution', st)
      if (.not. is_ok(st)) return
    end if
    if (present(u_start)) then
      if (size(u_start) /= problem%mesh%nnode) then
        call set_error(st, DS_ERR_INPUT, 'analysis: u_start has ' // itoa(size(u_start)) // ' values for ' // &
          itoa(problem%mesh%nnode) // ' nodes')
        return
      end if
      an%u_start = u_start
    end if
    an%problem = problem
    ! markers left unallocated: Gamma_u none; Gamma_a none for P2, every marker of the mesh for
    ! P1 (its Signorini conditions hold on all of Gamma)
    if (.not. allocated(an%problem%gamma_u)) allocate (an%problem%gamma_u(0))   ! small: empty
    if (.not. allocated(an%problem%gamma_a)) then
      if (problem%kind == PROBLEM_P1 .and. allocated(an%problem%mesh%bedge_marker)) then
        an%problem%gamma_a = mesh_boundary_markers(an%problem%mesh)
      else
        allocate (an%problem%gamma_a(0))                                       ! small: empty
      end if
    end if
    an%settings = settings
    an%dual_method = method
    ! the levels' mesh: the copy of the coarse mesh moved out of an%problem (one copy, not two)
    call mesh_move(an%problem%mesh, an%mesh)
    ! (a mesh whose adjacency a primal-only run released: rebuilt for the geometry checks)
    if (allocated(an%mesh%edge_nodes)) call mesh_ensure_adjacency(an%mesh, st)
    if (.not. is_ok(st)) return
    an%level = 0
    an%load_rule = tri_rule(load_degree)
    an%t_start = wall_seconds()
    if (allocated(problem%u_exact)) an%exact_rule = tri_rule(exact_degree)
    if (settings%dual) then
      an%bound_rule_p1 = tri_rule(bound_degree_p1)
      an%bound_rule_p2 = tri_rule(bound_degree_p2)
    end if
    an%started = .true.
  end subroutine analysis_start

  !> The next level: the coarse mesh on the first call, then one uniform refinement of the
  !> previous level, its solution prolongated as the start when settings%nested.  An error
  !> leaves res partly filled and the analysis at the previous level.
  subroutine analysis_next_level(an, res, st)
    type(analysis_t), intent(inout) :: an
    type(level_result_t), intent(out) :: res
    type(status_t), intent(out) :: st
    type(mesh_t) :: finer
    real(dp), allocatable :: u_next(:)
    integer, allocatable :: parents(:,:)
    real(dp) :: t0
    integer :: ist
    t0 = wall_seconds()
    if (.not. an%started) then
      call set_error(st, DS_ERR_INPUT, 'analysis_next_level: the analysis was not started (call analysis_start ' // &
        'first; after analysis_free, start it again)')
      return
    end if
    if (an%level > 0) then
      call phase_event(an, an%level + 1, 'refine', .false., 0.0_dp)
      if (allocated(an%mesh%edge_nodes)) call mesh_ensure_adjacency(an%mesh, st)
      if (is_ok(st)) call mesh_refine_uniform(an%mesh, finer, st)
      if (.not. is_ok(st)) return
      if (an%mg%nlevel > 0) call mg_add_level(an%mg, an%mesh%nnode, an%mesh%edge_nodes, st)
      if (.not. is_ok(st)) return
      if (an%settings%nested) then
        allocate (u_next(finer%nnode), stat=ist)
        if (alloc_failed(ist, st, 'the prolongated solution', finer%nnode, BYTES_REAL)) return
        call mesh_prolongate_p1(an%mesh, finer, an%u, u_next)
      end if
      if (allocated(an%nest%q)) then
        call prolongate_q_hdiv(an, finer, st)
        if (.not. is_ok(st)) return
      end if
      if (allocated(an%psi)) call prolongate_psi(an, finer, st)
      if (allocated(an%flux_f) .and. is_ok(st)) then   ! new node nnode + e: the midpoint of edge e
        parents = an%mesh%edge_nodes
        call prolongate_flux_bisection(an, finer, parents, st)
      end if
      if (.not. is_ok(st)) return
      call mesh_move(finer, an%mesh)
      call phase_event(an, an%level + 1, 'refine', .true., wall_seconds() - t0)
    else if (allocated(an%u_start)) then
      u_next = an%u_start
    end if
    ! the grids of the uniform refinements: for the primal's multigrid, and for the P2 dual's
    ! stream function (p2_dual_choice) whatever the primal method
    if (an%level == 0 .and. (any(an%settings%method == [character(len=16) :: 'multigrid', 'auto']) .or. &
        (an%problem%kind /= PROBLEM_P1 .and. an%settings%dual .and. any(an%dual_method == &
        [character(len=16) :: 'auto', 'multigrid'])))) call mg_reset(an%mg, an%mesh%nnode)
    if (.not. allocated(u_next)) then
      allocate (u_next(an%mesh%nnode), stat=ist)
      if (alloc_failed(ist, st, 'the primal solution', an%mesh%nnode, BYTES_REAL)) return
      u_next = 0.0_dp
    end if
    call move_alloc(u_next, an%u)
    an%level = an%level + 1
    res%level = an%level
    res%refine_seconds = wall_seconds() - t0
    call solve_level(an, res, st)
    call finish_level(an, res, t0)
    ! the last level, or a failed one: the factorisations the hierarchies keep (CHOLMOD
    ! memory, outside Fortran's) are released; analysis_free releases them otherwise
    if ((an%level >= an%settings%levels .and. .not. an%settings%keep_hierarchy) .or. .not. is_ok(st)) then
      call mg_clear(an%mg)
      call dual_hdiv_nested_free(an%nest)
    end if
  end subroutine analysis_next_level

  !> One step of the adaptive loop solve -> estimate -> mark -> refine: the coarse mesh on
  !> the first call; later, the triangles of the previous step marked by Doerfler's
  !> criterion on its element indicators est_elem (the local terms of E of (6.13)/(6.26)),
  !> refined by newest-vertex bisection with conforming closure, the previous u_h carried
  !> over (exact P1 interpolation: new nodes are edge midpoints) as the start of the solve,
  !> whose active set it predicts (the contact set is transferred with it).  The mesh
  !> changes every step, so the ordering and the factorisations are those of a new matrix.
  !> An error leaves res partly filled and the analysis at the previous step.
  subroutine analysis_next_step(an, res, st)
    type(analysis_t), intent(inout) :: an
    type(level_result_t), intent(out) :: res
    type(status_t), intent(out) :: st
    type(mesh_t) :: finer
    integer, allocatable :: parents(:,:)
    real(dp), allocatable :: u_next(:), eta2(:)
    real(dp) :: t0, floor
    integer :: t, ist
    if (an%level == 0 .or. .not. an%started) then     ! (not started: analysis_next_level says so)
      call analysis_next_level(an, res, st)
      if (is_ok(st)) res%max_depth = 0
      return
    end if
    t0 = wall_seconds()
    if (.not. allocated(an%est_elem)) then
      call set_error(st, DS_ERR_INPUT, 'analysis: adaptive step ' // itoa(an%level + 1) // ' needs the element ' // &
        'indicators of the previous step (dual analysis with bounds)')
      return
    end if
    call phase_event(an, an%level + 1, 'refine', .false., 0.0_dp)
    ! Doerfler's criterion among the triangles that can still be bisected in double precision
    eta2 = an%est_elem
    floor = adapt_side_floor * epsilon(1.0_dp) * mesh_coordinate_scale(an%mesh)
    do t = 1, an%mesh%ntri
      if (mesh_longest_side(an%mesh, t) <= floor .and. eta2(t) > 0.0_dp) then
        eta2(t) = 0.0_dp
        res%nheld = res%nheld + 1
      end if
    end do
    call mesh_ensure_adjacency(an%mesh, st)
    if (is_ok(st)) call mark_and_refine(an, eta2, finer, parents, res, st)
    if (.not. is_ok(st)) return
    if (allocated(an%tri_origin)) deallocate (an%tri_origin)
    if (allocated(an%load_keep%mean)) then      ! the whole triangles keep their load data
      allocate (an%tri_origin(finer%ntri), stat=ist)
      if (alloc_failed(ist, st, 'the origins of the refined triangles', finer%ntri, BYTES_INT)) return
      call mesh_bisection_origin(an%mesh, finer, an%tri_origin)
    end if
    call dual_hdiv_nested_free(an%nest)   ! 'nested' needs a uniform refinement
    call mg_clear(an%mg)                    ! not a uniform refinement: no multigrid hierarchy
    if (allocated(an%psi)) call prolongate_psi_bisection(an, finer, parents, st)
    if (allocated(an%flux_f) .and. is_ok(st)) call prolongate_flux_bisection(an, finer, parents, st)
    if (.not. is_ok(st)) return
    allocate (u_next(finer%nnode), stat=ist)
    if (alloc_failed(ist, st, 'the prolongated solution', finer%nnode, BYTES_REAL)) return
    call mesh_prolongate_bisection(parents, an%u, u_next)
    call mesh_move(finer, an%mesh)
    call move_alloc(u_next, an%u)
    an%level = an%level + 1
    res%level = an%level
    res%max_depth = maxval(an%mesh%tri_gen)
    res%refine_seconds = wall_seconds() - t0
    call phase_event(an, an%level, 'refine', .true., res%refine_seconds)
    call solve_level(an, res, st)
    call finish_level(an, res, t0)
  end subroutine analysis_next_step

  !> Doerfler's marks on eta2 and their newest-vertex bisection (an%mesh -> finer, parents
  !> of dualsig_mesh_adapt), with the new nodes kept in a window of the unknowns ndof:
  !> - a step that aims at tol (analysis_aim_growth: the growth g the observed rate asks
  !>   for, adapt_aim_margin included) adds at least (g / adapt_aim_margin - 1) ndof and
  !>   at most (g - 1) ndof new nodes;
  !> - any other step at least (min_growth - 1) ndof;
  !> - a step limited by analysis_limit_growth (memory) at most (limit - 1) ndof.
  !> The marks are Doerfler's set cut to, or extended by, the largest indicators; their
  !> number starts from the last bisection's new nodes per mark and is corrected in
  !> proportion to the new nodes obtained, the bisection redone (adapt_aim_tries times;
  !> a bisection costs about 3 % of a step); a step still above its aim then halves its
  !> marks until it is within (the upper bound always holds, down to one mark).
  !> res%nmarked, res%aim_growth.
  subroutine mark_and_refine(an, eta2, finer, parents, res, st)
    type(analysis_t), intent(inout) :: an
    real(dp), intent(in) :: eta2(:)
    type(mesh_t), intent(out) :: finer
    integer, allocatable, intent(out) :: parents(:,:)
    type(level_result_t), intent(inout) :: res
    type(status_t), intent(out) :: st
    logical, allocatable :: marked(:)
    integer :: try, cap, least, nnew, max_new, min_new, nmarkable
    real(dp) :: ndof
    ndof = real(max(an%last_ndof, 1), dp)
    res%aim_growth = analysis_aim_growth(an)
    max_new = huge(1)
    min_new = ceiling((an%settings%adapt%min_growth - 1.0_dp) * ndof)
    if (res%aim_growth > 0.0_dp) then
      max_new = max(1, int((res%aim_growth - 1.0_dp) * ndof))
      min_new = min(max_new, ceiling((res%aim_growth / adapt_aim_margin - 1.0_dp) * ndof))
    end if
    if (an%growth_limit > 1.0_dp) then               ! the memory's limit (analysis_limit_growth)
      max_new = min(max_new, max(1, int((an%growth_limit - 1.0_dp) * ndof)))
      min_new = min(min_new, max_new)
    end if
    an%growth_limit = 0.0_dp
    nmarkable = count(eta2 > 0.0_dp)
    cap = huge(1)
    least = 0
    if (an%new_per_mark > 0.0_dp) then        ! the last bisection's yield: one try as a rule
      if (max_new < huge(1)) cap = max(1, int(adapt_aim_shrink * real(max_new, dp) / an%new_per_mark))
      least = min(cap, ceiling(real(min_new, dp) / (adapt_aim_shrink * an%new_per_mark)))
    end if
    do try = 1, adapt_aim_tries + adapt_aim_halvings
      call mesh_mark_doerfler(eta2, an%settings%adapt%theta, marked, res%nmarked, st, max_marked=cap, &
                              min_marked=least)
      if (.not. is_ok(st)) return
      if (res%nmarked == 0) then
        call set_error(st, DS_ERR_INPUT, 'analysis: adaptive step ' // itoa(an%level + 1) // ': no triangle to ' // &
          'mark (every indicator is zero, or ' // itoa(res%nheld) // ' triangle(s) with positive ones are at the ' // &
          'size floor of double precision)')
        return
      end if
      call mesh_refine_marked(an%mesh, marked, finer, parents, st)
      if (.not. is_ok(st)) return
      nnew = finer%nnode - an%mesh%nnode
      an%new_per_mark = real(nnew, dp) / real(res%nmarked, dp)
      if (nnew > max_new .and. res%nmarked > 1) then
        cap = max(1, int(adapt_aim_shrink * real(res%nmarked, dp) * real(max_new, dp) / real(nnew, dp)))
        if (try >= adapt_aim_tries) cap = max(1, res%nmarked / 2)
        least = min(least, cap)
      else if (try >= adapt_aim_tries) then
        exit                                       ! within the aim, short of min_new: kept
      else if (nnew < min_new .and. res%nmarked < nmarkable) then
        least = ceiling(real(res%nmarked, dp) * real(min_new, dp) / (adapt_aim_shrink * real(nnew, dp)))
        if (cap < huge(1)) cap = max(cap, least)
      else
        exit
      end if
    end do
  end subroutine mark_and_refine

  !> Limit the next adaptive step (analysis_next_step) to at most `growth` times the
  !> unknowns of the last step (growth > 1; the memory a larger step would need is not
  !> there): Doerfler's set, or the aim at tol, is cut to that many new nodes.
  subroutine analysis_limit_growth(an, growth)
    type(analysis_t), intent(inout) :: an
    real(dp), intent(in) :: growth
    an%growth_limit = growth
  end subroutine analysis_limit_growth

  !> The growth ndof_next / ndof of the unknowns with which the next adaptive step aims at
  !> the settings' tol (adapt_aim_growth of the last two steps); 0: no aim (no tol, fewer
  !> than two steps, no certified decay, or tol too far for one step).
  pure real(dp) function analysis_aim_growth(an) result(growth)
    type(analysis_t), intent(in) :: an
    growth = 0.0_dp
    if (.not. an%settings%adapt%enabled .or. an%level < 2) return
    growth = adapt_aim_growth(an%last_ndof, an%prev_ndof, an%last_rel, an%prev_rel, an%settings%adapt%tol)
  end function analysis_aim_growth

  !> The growth of the unknowns that reaches tol from a step with ndof unknowns and the
  !> certified relative error rel, after one with ndof_prev and rel_prev: with the observed
  !> rate p = log(rel_prev / rel) / log(ndof / ndof_prev), at most adapt_aim_rate_max,
  !> adapt_aim_margin (rel / tol)^(1/p).  0 when it does not apply: no tol, tol reached, no
  !> decay, p below adapt_aim_rate_min, or a growth beyond adapt_aim_growth_max (a step
  !> that Doerfler's set does not overshoot).
  pure real(dp) function adapt_aim_growth(ndof, ndof_prev, rel, rel_prev, tol) result(growth)
    integer, intent(in) :: ndof, ndof_prev
    real(dp), intent(in) :: rel, rel_prev, tol
    real(dp) :: p, log_growth
    growth = 0.0_dp
    if (.not. (tol > 0.0_dp) .or. ndof_prev <= 0 .or. ndof <= ndof_prev) return
    if (.not. (rel > tol .and. rel < rel_prev .and. rel_prev < huge(1.0_dp))) return
    p = log(rel_prev / rel) / log(real(ndof, dp) / real(ndof_prev, dp))
    if (p < adapt_aim_rate_min) return
    p = min(p, adapt_aim_rate_max)
    log_growth = log(adapt_aim_margin) + log(rel / tol) / p
    if (log_growth > log(adapt_aim_growth_max)) return
    growth = exp(log_growth)
  end function adapt_aim_growth

  !> Bookkeeping after a level or step that started at wall time t0: its timings, its
  !> indicators for the next marking, its size for the stopping test.
  subroutine finish_level(an, res, t0)
    type(analysis_t), intent(inout) :: an
    type(level_result_t), intent(inout) :: res
    real(dp), intent(in) :: t0
    real(dp) :: now
    now = wall_seconds()
    res%step_seconds = now - t0
    res%elapsed_seconds = now - an%t_start
    an%last_step_seconds = res%step_seconds
    an%prev_ndof = an%last_ndof
    an%last_ndof = res%ndof
    an%prev_rel = an%last_rel
    an%last_rel = certified_rel_error(res)
    an%last_est = merge(res%est, 0.0_dp, res%has_dual)
    if (allocated(an%est_elem)) deallocate (an%est_elem)
    if (allocated(res%est_elem)) an%est_elem = res%est_elem
  end subroutine finish_level

  !> The certified relative error sqrt(est / energy_lo) of a level: huge when the level is
  !> not certified or energy_lo <= energy_lo_rel_floor energy_hi (no useful guaranteed
  !> relative error yet).
  pure real(dp) function certified_rel_error(res) result(rel)
    type(level_result_t), intent(in) :: res
    rel = huge(1.0_dp)
    if (res%has_dual .and. res%certified .and. res%energy_lo > 0.0_dp .and. &
        res%energy_lo > energy_lo_rel_floor * res%energy_hi) rel = sqrt(max(res%est, 0.0_dp) / res%energy_lo)
  end function certified_rel_error

  !> Whether the adaptive loop stops after the step res (ADAPT_*): tol reached by a
  !> certified step; max_ndof reached; the next step, predicted to take the last step's
  !> time scaled by the growth of the unknowns, would end after max_seconds; max_steps done.
  pure integer function analysis_adapt_stop(an, res) result(reason)
    type(analysis_t), intent(in) :: an
    type(level_result_t), intent(in) :: res
    real(dp) :: growth
    reason = ADAPT_GOING
    associate (ad => an%settings%adapt)
      if (ad%tol > 0.0_dp .and. certified_rel_error(res) <= ad%tol) then
        reason = ADAPT_STOP_TOL
      else if (ad%max_ndof > 0 .and. res%ndof >= ad%max_ndof) then
        reason = ADAPT_STOP_NDOF
      else if (an%level >= min(ad%max_steps, adapt_max_steps)) then
        reason = ADAPT_STOP_STEPS
      else if (ad%max_seconds > 0.0_dp) then
        growth = 2.0_dp
        if (an%prev_ndof > 0) growth = max(1.0_dp, real(an%last_ndof, dp) / real(an%prev_ndof, dp))
        if (res%elapsed_seconds + an%last_step_seconds * growth > ad%max_seconds) reason = ADAPT_STOP_SECONDS
      end if
    end associate
  end function analysis_adapt_stop

  !> What a stop reason means, for tables and messages.
  function adapt_stop_text(reason, ad) result(text)
    integer, intent(in) :: reason
    type(adapt_settings_t), intent(in) :: ad
    character(len=:), allocatable :: text
    select case (reason)
    case (ADAPT_STOP_TOL)
      text = 'tol: the certified relative error sqrt(est/energy_lo) reached tol = ' // rtoa(ad%tol)
    case (ADAPT_STOP_NDOF)
      text = 'max_ndof: the step reached max_ndof = ' // itoa(ad%max_ndof) // ' unknowns before tol'
    case (ADAPT_STOP_SECONDS)
      text = 'max_seconds: the next step would end after max_seconds = ' // rtoa(ad%max_seconds) // ' before tol'
    case (ADAPT_STOP_STEPS)
      text = 'max_steps: ' // itoa(min(ad%max_steps, adapt_max_steps)) // ' steps done before tol'
    case default
      text = 'going on'
    end select
  end function adapt_stop_text

  !> Release what an analysis holds.
  subroutine analysis_free(an)
    type(analysis_t), intent(inout) :: an
    call dual_hdiv_nested_free(an%nest)
    call mg_clear(an%mg)
    an = analysis_t()
  end subroutine analysis_free

  !> The P2 dual's stream function of the last level (method 'multigrid') on the uniform
  !> refinement `finer`: the start of the next level's solve.
  subroutine prolongate_psi(an, finer, st)
    type(analysis_t), intent(inout) :: an
    type(mesh_t), intent(in) :: finer
    type(status_t), intent(inout) :: st
    real(dp), allocatable :: psi_f(:)
    integer, allocatable :: set_f(:,:)
    if (size(an%psi) /= an%mesh%nnode + an%mesh%nedge) then
      deallocate (an%psi)
      return
    end if
    call stream_prolongate(an%mesh, finer, an%psi, psi_f, st)
    if (is_ok(st)) call move_alloc(psi_f, an%psi)
    if (allocated(an%psi_set) .and. is_ok(st)) then
      call stream_prolongate_set(an%psi_set, set_f, st)
      if (is_ok(st)) call move_alloc(set_f, an%psi_set)
    end if
  end subroutine prolongate_psi

  !> The P2 dual's stream function of the last adaptive step (method 'multigrid') and its
  !> active set on Gamma_a, carried to the bisection `finer` (parents: mesh_refine_marked's):
  !> the start of the next step's solve (a cold start took 9-12 V-cycles a step on the
  !> adaptive transition case, doc/performance.md).  Dropped when not of this mesh or when
  !> it cannot be carried over (the next solve then starts cold); only running out of
  !> memory stops the step.
  subroutine prolongate_psi_bisection(an, finer, parents, st)
    type(analysis_t), intent(inout) :: an
    type(mesh_t), intent(in) :: finer
    integer, intent(in) :: parents(:,:)
    type(status_t), intent(inout) :: st
    type(status_t) :: st_carry
    real(dp), allocatable :: psi_f(:)
    integer, allocatable :: set_f(:,:)
    logical :: carried, set_carried
    carried = size(an%psi) == an%mesh%nnode + an%mesh%nedge
    if (carried) then
      call stream_prolongate_bisection(an%mesh, finer, parents, an%psi, psi_f, st_carry)
      carried = is_ok(st_carry)
      if (carried) call move_alloc(psi_f, an%psi)
    end if
    set_carried = .false.
    if (carried .and. allocated(an%psi_set)) then
      if (size(an%psi_set, 2) == an%mesh%nbedge) then
        call stream_prolongate_set_bisection(an%mesh, finer, an%psi_set, set_f, st_carry)
        set_carried = is_ok(st_carry)
        if (set_carried) call move_alloc(set_f, an%psi_set)
      end if
    end if
    if (.not. carried) deallocate (an%psi)
    if (allocated(an%psi_set) .and. .not. set_carried) deallocate (an%psi_set)
    if (st_carry%code == DS_ERR_MEMORY) st = st_carry
  end subroutine prolongate_psi_bisection

  !> The last level's polynomial lambda^f (an%flux_f) as a field of the refinement `finer`,
  !> a bisection or the uniform refinement (parents: the coarse node pair of every new node;
  !> equilibrium_prolongate_bisection, exact): the start of the next level's lambda^f.  The
  !> equilibration then moves only the change of the load means, which sums to zero over
  !> every refined triangle, so the new lambda^f stays close to the old and the carried psi
  !> stays a close start (rebuilt from zero, lambda^f changed by O(1) every step,
  !> and the stream function's first CG step removed 2.7 of J where the share asked 1e-9).
  !> Dropped when it cannot be carried (the next step's lambda^f starts from zero); only
  !> running out of memory stops the step.
  subroutine prolongate_flux_bisection(an, finer, parents, st)
    type(analysis_t), intent(inout) :: an
    type(mesh_t), intent(in) :: finer
    integer, intent(in) :: parents(:,:)
    type(status_t), intent(inout) :: st
    type(status_t) :: st_carry
    real(dp), allocatable :: flux_fine(:)
    integer, allocatable :: ancestor(:)
    logical :: ok
    integer :: ist
    ok = size(an%flux_f) == 2 * an%mesh%nedge
    if (ok) then
      allocate (ancestor(finer%ntri), stat=ist)
      if (alloc_failed(ist, st, 'the ancestors of the refined triangles', finer%ntri, BYTES_INT)) return
      call mesh_bisection_ancestor(an%mesh, finer, parents, ancestor, ok)
    end if
    if (ok) then
      call equilibrium_prolongate_bisection(an%mesh, finer, ancestor, parents, an%flux_f, flux_fine, st_carry)
      ok = is_ok(st_carry)
      if (st_carry%code == DS_ERR_MEMORY) st = st_carry
    end if
    if (ok) then
      call move_alloc(flux_fine, an%flux_f)
    else
      deallocate (an%flux_f)
    end if
  end subroutine prolongate_flux_bisection

  !> Dual method 'nested': the RT1 field of the level an%mesh as a field of its uniform
  !> refinement `finer` (exact, hdiv_prolongate), the start of the next level's dual solve,
  !> and the prolongation of its multigrid.
  subroutine prolongate_q_hdiv(an, finer, st)
    type(analysis_t), intent(inout) :: an
    type(mesh_t), intent(in) :: finer
    type(status_t), intent(inout) :: st
    an%prolong_seconds = wall_seconds()
    ! the last level of the run (its hierarchy would be released after it) is solved by the
    ! matrix-free sweeps as far as dual_algebraic_share allows; share 0 asks for the solve
    call dual_hdiv_nested_refine(an%nest, an%mesh, finer, st, last=an%level + 1 >= an%settings%levels .and. &
                                 .not. an%settings%keep_hierarchy .and. an%settings%dual_algebraic_share > 0.0_dp)
    an%prolong_seconds = wall_seconds() - an%prolong_seconds
  end subroutine prolongate_q_hdiv

  !> One level on an%mesh from the start an%u: the geometry checks (mesh_check_geometry),
  !> assemble, constraints, primal solve, exact errors, dual solve and bounds.
  subroutine solve_level(an, res, st)
    type(analysis_t), intent(inout) :: an
    type(level_result_t), intent(inout) :: res
    type(status_t), intent(out) :: st
    type(primal_system_t) :: sys
    real(dp) :: t0, t_verify
    associate (mesh => an%mesh, pb => an%problem)
      res%nnode = mesh%nnode
      res%ntri = mesh%ntri
      t0 = wall_seconds()
      call phase_event(an, an%level, 'assemble', .false., 0.0_dp)
      ! no solve on a folded, doubled or broken mesh: the bounds assume triangles tiling the domain once
      call mesh_check_geometry(mesh, st)
      if (.not. is_ok(st)) then
        if (index(st%msg, 'mesh: ') == 1) st%msg = st%msg(len('mesh: ') + 1:)
        st%msg = 'analysis: the mesh of level ' // itoa(an%level) // ': ' // st%msg
        return
      end if
      res%h = mesh_h(mesh)
      ! the last level of a primal-only run needs no adjacency (edge_tri, tri_edge and the
      ! boundary links of the nodes): released before the matrix and the solver take their
      ! memory (analysis_start, analysis_next_level and analysis_next_step rebuild it when a
      ! caller goes on from this mesh)
      if (an%level >= an%settings%levels .and. .not. an%settings%dual .and. .not. an%settings%adapt%enabled) &
        call mesh_release_adjacency(mesh)
      call primal_assemble(mesh, pb%kind, pb%f, an%load_rule, sys, st)
      if (.not. is_ok(st)) return
      if (.not. all(ieee_is_finite(sys%load))) then
        call set_error(st, DS_ERR_NUMERIC, 'analysis: level ' // itoa(an%level) // ': the load vector is not ' // &
          'finite: f is NaN or infinite at a quadrature point, or its integrals overflow (expected a finite f ' // &
          'of moderate size on the whole domain)')
        return
      end if
      call primal_constraints(mesh, pb%kind, pb%gamma_u, pb%gamma_a, sys%kind, sys%bnd, st, &
                              every_loop_gamma_u=an%settings%dual .and. pb%kind /= PROBLEM_P1)
      if (.not. is_ok(st)) return
      res%ndof = count(sys%kind /= BOUND_FIXED)
      call phase_event(an, an%level, 'assemble', .true., wall_seconds() - t0)
      call phase_event(an, an%level, 'primal solve', .false., 0.0_dp)
      call solve_primal(an, sys, res, st)
      if (.not. is_ok(st)) then
        call explain_small_p1_domain(mesh, pb%kind, st)
        return
      end if
      call phase_event(an, an%level, 'primal solve', .true., res%primal_seconds)
      res%u = an%u
      call move_alloc(sys%kind, res%bound_kind)
      call move_alloc(sys%bnd, res%bound)
      if (allocated(pb%u_exact)) then
        t0 = wall_seconds()
        call primal_errors(an, res)
        res%verify_seconds = wall_seconds() - t0
      end if
      if (an%settings%dual) then
        call phase_event(an, an%level, 'dual analysis', .false., 0.0_dp)
        t_verify = res%verify_seconds
        res%estimate_seconds = wall_seconds()
        if (pb%kind == PROBLEM_P1) then
          call dual_level_p1(an, res, st)
          if (.not. is_ok(st)) call explain_small_p1_domain(mesh, pb%kind, st)
        else
          call dual_level_p2(an, res, st)
        end if
        res%estimate_seconds = wall_seconds() - res%estimate_seconds - (res%verify_seconds - t_verify)
        if (is_ok(st)) call phase_event(an, an%level, 'dual analysis', .true., res%estimate_seconds)
      end if
      if (is_ok(st)) call check_finite_results(an%level, res, st)
      if (is_ok(st)) call check_representable_bounds(an, res)
      if (is_ok(st)) call check_exact_solution(an%level, pb%kind, res, st)
    end associate
  end subroutine solve_level

  !> A numerical failure of the P1 primal on a small domain gets its likely cause: -Lap u + u
  !> is not scale-invariant; the mass matrix of the reaction term is about h^2 times the
  !> stiffness matrix, so on a domain of diameter below p1_small_domain K + M is singular to
  !> rounding (or nearly: the solvers stall or a pivot vanishes).
  subroutine explain_small_p1_domain(mesh, kind, st)
    type(mesh_t), intent(in) :: mesh
    integer, intent(in) :: kind
    type(status_t), intent(inout) :: st
    real(dp) :: d, w(2), aspect
    integer :: t
    if (kind /= PROBLEM_P1 .or. .not. (st%code == DS_ERR_NUMERIC .or. st%code == DS_ERR_LAPACK)) return
    d = mesh_diameter(mesh)
    w = maxval(mesh%xy(:, 1:mesh%nnode), dim=2) - minval(mesh%xy(:, 1:mesh%nnode), dim=2)
    if (d < p1_small_domain) then
      st%msg = st%msg // ' (the domain''s diameter is ' // rtoa(d) // ': problem P1, -Lap u + u = f, is not ' // &
        'scale-invariant, and its reaction term u weighs about h^2 = ' // rtoa(mesh_h(mesh)**2) // ' against ' // &
        'the diffusion term, so the system is singular to rounding; expected coordinates in units where the ' // &
        'domain has a moderate size)'
    else
      ! stretched triangles (a thin domain with few cells across its length): across them the
      ! couplings of the diffusion term are about aspect^2 times those along them and the
      ! reaction term's, which fall below rounding
      aspect = 0.0_dp
      do t = 1, mesh%ntri
        aspect = max(aspect, mesh_longest_side(mesh, t)**2 / (2.0_dp * abs(mesh_triangle_area(mesh, t))))
      end do
      if (aspect > p1_stretched) st%msg = st%msg // ' (the domain is ' // rtoa(w(1)) // ' by ' // rtoa(w(2)) // &
        ' and its triangles are stretched to an aspect ratio of ' // rtoa(aspect) // ': problem P1, -Lap u + ' // &
        'u = f, then has couplings along them and a reaction term about ' // rtoa(aspect**(-2)) // ' times ' // &
        'those across them, below rounding, so the system is singular; expected triangles of moderate aspect ' // &
        'ratio, e.g. more cells along the domain)'
    end if
  end subroutine explain_small_p1_domain

  !> The error of u_h against the given exact solution can never exceed a certified bound:
  !> ||u - u_h||^2 <= est (6.13) for P1, |u - u_h|_1^2 <= est (6.26) for P2, for the
  !> solution u of the problem posed.  A certified level with err^2 > (1 +
  !> exact_consistency_tol) est therefore proves that u_exact is not that solution (its
  !> boundary conditions were checked by exact_boundary_check, so f and u_exact disagree, or
  !> u_exact is singular between the nodes): DS_ERR_INPUT, since its error columns and eff
  !> would be meaningless.
  subroutine check_exact_solution(level, kind, res, st)
    integer, intent(in) :: level
    integer, intent(in) :: kind              !! PROBLEM_P1 or PROBLEM_P2
    type(level_result_t), intent(inout) :: res
    type(status_t), intent(inout) :: st
    character(len=:), allocatable :: pde
    if (.not. (res%has_exact .and. res%has_dual .and. res%certified)) return
    if (.not. (res%err_energy**2 > (1.0_dp + exact_consistency_tol) * res%est)) return
    if (kind == PROBLEM_P1) then
      pde = '-Lap u + u = f'
    else
      pde = '-Lap u = f'
    end if
    res%exact_refuted = .true.
    call set_error(st, DS_ERR_INPUT, 'analysis: level ' // itoa(level) // ': the error against the exact ' // &
      'solution, ' // rtoa(res%err_energy) // ', exceeds the guaranteed bound sqrt(est) = ' // &
      rtoa(sqrt(max(res%est, 0.0_dp))) // ', which holds for the solution of the problem posed: the exact ' // &
      'solution given is not that solution (expected u_exact with ' // pde // ' in the domain, smooth ' // &
      'between the nodes); its error columns would be meaningless')
  end subroutine check_exact_solution

  !> A level whose bounds fell below the range where double precision keeps its digits is
  !> not certified: est and energy_hi must be at least representable_floor (or est exactly 0)
  !> when u_h is not 0.  Both are quadratic in the data, so |f| of 1e-150 or less (or a
  !> domain scaled far from 1) puts them there, and their subnormal or underflowed values
  !> (eff < 1 and "certified" zero bounds were seen at |f| = 1e-160 and 1e-200) are no bounds.
  subroutine check_representable_bounds(an, res)
    type(analysis_t), intent(in) :: an
    type(level_result_t), intent(inout) :: res
    if (.not. (res%has_dual .and. res%certified)) return
    if (.not. allocated(an%u)) return
    if (all(an%u == 0.0_dp)) return                 ! the zero problem: 0 bounds are exact
    if (res%energy_hi >= representable_floor .and. (res%est == 0.0_dp .or. res%est >= representable_floor)) return
    res%certified = .false.
    call add_warning(res, DS_WARN_NOT_CERTIFIED, 'est = ' // rtoa(res%est) // ' and energy_hi = ' // &
      rtoa(res%energy_hi) // ' are below ' // rtoa(representable_floor) // ', where double precision loses ' // &
      'digits: the bounds are NOT certified (expected a problem scaled to moderate sizes: the bounds scale ' // &
      'with the square of f)')
  end subroutine check_representable_bounds

  !> Report the start or the end of a phase to the settings' progress callback, if any.
  subroutine phase_event(an, level, phase, finished, seconds)
    type(analysis_t), intent(in) :: an
    integer, intent(in) :: level
    character(len=*), intent(in) :: phase
    logical, intent(in) :: finished
    real(dp), intent(in) :: seconds
    if (associated(an%settings%progress)) call an%settings%progress(level, phase, finished, seconds)
  end subroutine phase_event

  !> A level's solution and bounds must be finite: f may be NaN between the points where it
  !> was checked, or so large that the energies overflow.  DS_ERR_NUMERIC otherwise.
  subroutine check_finite_results(level, res, st)
    integer, intent(in) :: level
    type(level_result_t), intent(in) :: res
    type(status_t), intent(inout) :: st
    character(len=*), parameter :: why = ' (f is NaN or infinite somewhere in the domain, or so large ' // &
      'that the energies overflow; expected a finite f of moderate size)'
    if (allocated(res%u)) then
      if (.not. all(ieee_is_finite(res%u))) then
        call set_error(st, DS_ERR_NUMERIC, 'analysis: level ' // itoa(level) // ': the primal solution u_h is not ' // &
          'finite' // why)
        return
      end if
    end if
    if (.not. res%has_dual) return
    if (.not. (ieee_is_finite(res%est) .and. ieee_is_finite(res%energy_lo) .and. ieee_is_finite(res%energy_hi))) then
      call set_error(st, DS_ERR_NUMERIC, 'analysis: level ' // itoa(level) // ': the bounds are not finite' // why)
    end if
  end subroutine check_finite_results

  !> The primal QP (Section 2) from an%u; the result replaces an%u.  Methods: 'schur' (one
  !> CHOLMOD factorisation with the bounded unknowns eliminated last, the exact dense QP on
  !> their Schur complement, one back substitution: dualsig_solver_boundary_schur), the
  !> primal-dual active-set method (one CHOLMOD factor, changes bordered), both with the
  !> ordering chosen by select_ordering, or projected SOR (omega given or from a Lanczos
  !> estimate).  'auto': see primal_method_of; when its 'multigrid_amg' does not converge
  !> (max_iter) or fails, the level is solved again by 'schur' or 'active_set' (the same rule).
  subroutine solve_primal(an, sys, res, st)
    type(analysis_t), intent(inout) :: an
    type(primal_system_t), intent(in) :: sys
    type(level_result_t), intent(inout) :: res
    type(status_t), intent(out) :: st
    type(active_set_settings_t) :: aset
    type(active_set_result_t) :: ares
    type(psor_settings_t) :: pset
    type(psor_result_t) :: pres
    type(status_t) :: st_solve
    real(dp) :: lmin, lmax
    integer :: steps
    res%primal_seconds = wall_seconds()
    res%primal_method = primal_method_of(an%settings, sys%kind, an%mg%nlevel)
    if (res%primal_method == 'multigrid' .or. res%primal_method == 'multigrid_amg') then
      call solve_primal_multigrid(an, sys, res, st_solve)
      if (res%primal_method == 'multigrid_amg' .and. an%settings%method == 'auto' .and. st_solve%code /= DS_OK) then
        ! 'auto' falls back on a factorisation when the algebraic multigrid fails or stalls
        if (.not. is_ok(st_solve)) an%u = 0.0_dp
        res%primal_method = merge('schur     ', 'active_set', count(sys%kind == BOUND_LOWER) <= an%settings%max_schur)
      end if
    end if
    if (res%primal_method == 'multigrid' .or. res%primal_method == 'multigrid_amg') then
      continue
    else if (res%primal_method == 'schur') then
      call solve_primal_schur(an, sys, res, st, st_solve)
      if (.not. is_ok(st)) return
    else if (res%primal_method == 'active_set') then
      aset%max_iter = an%settings%max_iter
      call select_ordering(an%settings%ordering, an%mesh%xy, sys%a, aset%ordering, aset%perm, st)
      if (.not. is_ok(st)) return
      call active_set_solve(sys%a, sys%load, sys%kind, sys%bnd, an%u, aset, ares, st_solve)
      res%primal_iters = ares%iterations
      res%primal_factorisations = ares%factorisations
      res%primal_bordered = ares%lowrank_solves
      res%kkt_residual = ares%kkt_residual
    else
      pset%omega = an%settings%omega
      pset%tol = an%settings%tol
      pset%max_iter = an%settings%max_iter
      pset%check_every = an%settings%check_every
      if (an%settings%omega_auto) then
        call jacobi_scaled_extremes(sys%a, sys%kind /= BOUND_FIXED, lanczos_max_steps, lanczos_rel_tol, &
                                    lmin, lmax, steps, st)
        if (.not. is_ok(st)) return
        pset%omega = sor_omega_from_jacobi(lmin, lmax)
      end if
      call psor_solve(sys%a, sys%load, sys%kind, sys%bnd, an%u, pset, pres, st_solve)
      res%primal_iters = pres%iterations
      res%kkt_residual = pres%kkt_residual
    end if
    res%primal_seconds = wall_seconds() - res%primal_seconds
    res%primal_limit = is_warning(st_solve)
    call take_status(st_solve, res, st)
  end subroutine solve_primal

  !> The primal method a level uses: settings%method, 'auto' resolved as 'multigrid' on a
  !> hierarchy of at least two uniform grids with more than mg_auto_min_unknowns unknowns
  !> (O(N), several times faster than one factorisation there: doc/performance.md), and as
  !> 'multigrid_amg' (the same multigrid on an algebraic hierarchy, smoothed aggregation of
  !> the level's matrix) above mg_auto_min_unknowns unknowns without such a hierarchy (level
  !> 1, Gmsh meshes, adaptive steps), else by the number of bounded unknowns ('schur' up to
  !> settings%max_schur, 'active_set' above).  'multigrid' without a hierarchy is
  !> 'multigrid_amg' above mg_auto_min_unknowns unknowns, 'auto' below.
  function primal_method_of(settings, kind, grids) result(method)
    type(analysis_settings_t), intent(in) :: settings
    integer, intent(in) :: kind(:)
    integer, intent(in) :: grids
    character(len=16) :: method
    method = settings%method
    if (any(method == [character(len=16) :: 'auto', 'multigrid']) .and. grids < 2 .and. &
        size(kind) > mg_auto_min_unknowns) method = 'multigrid_amg'
    if (method == 'multigrid' .and. grids < 2) method = 'auto'
    if (method == 'auto' .and. grids >= 2 .and. size(kind) > mg_auto_min_unknowns) method = 'multigrid'
    if (method == 'auto') method = merge('schur     ', 'active_set', count(kind == BOUND_LOWER) <= settings%max_schur)
  end function primal_method_of

  !> The primal QP by the boundary Schur complement: one factorisation whatever the start;
  !> the first active set of the dense QP from the unconstrained minimiser on a cold (zero)
  !> start, from the start's contact set otherwise.  st: errors of the ordering;
  !> st_solve: the solver's status.
  subroutine solve_primal_schur(an, sys, res, st, st_solve)
    type(analysis_t), intent(inout) :: an
    type(primal_system_t), intent(in) :: sys
    type(level_result_t), intent(inout) :: res
    type(status_t), intent(out) :: st, st_solve
    type(boundary_schur_settings_t) :: bset
    type(boundary_schur_result_t) :: bres
    call select_ordering(an%settings%ordering, an%mesh%xy, sys%a, bset%ordering, bset%perm, st)
    if (.not. is_ok(st)) return
    bset%qp%max_iter = min(an%settings%max_iter, bset%qp%max_iter)
    bset%guess_unconstrained = all(an%u == 0.0_dp)
    call boundary_schur_qp_solve(sys%a, sys%load, sys%kind, sys%bnd, an%u, bset, bres, st_solve)
    res%primal_iters = bres%qp_iterations
    res%primal_factorisations = bres%factorisations
    res%kkt_residual = bres%kkt_residual
    ! the pivoting limit reached: reported as every solver's limit (never called converged)
    if (is_ok(st_solve) .and. .not. bres%converged) call set_warning(st_solve, DS_WARN_NOT_CONVERGED, &
      'schur: the QP on the bounded unknowns stopped at its limit of ' // itoa(bset%qp%max_iter) // &
      ' pivoting steps (&solver max_iter), KKT residual ' // rtoa(bres%kkt_residual) // ' > tol')
  end subroutine solve_primal_schur

  !> The primal QP by truncated nonsmooth Newton multigrid (dualsig_solver_multigrid) on the
  !> grids of the uniform refinements so far ('multigrid') or on an algebraic hierarchy of
  !> the level's matrix built here and released after the solve ('multigrid_amg'), from
  !> an%u; at most min(max_iter, 200) V-cycles.
  subroutine solve_primal_multigrid(an, sys, res, st_solve)
    type(analysis_t), intent(inout) :: an
    type(primal_system_t), intent(in) :: sys
    type(level_result_t), intent(inout) :: res
    type(status_t), intent(out) :: st_solve
    type(mg_settings_t) :: mset
    type(mg_result_t) :: mres
    type(mg_hierarchy_t) :: amg
    mset%tol = an%settings%tol
    mset%max_iter = min(an%settings%max_iter, mset%max_iter)
    if (res%primal_method == 'multigrid_amg') then
      call mg_build_algebraic(amg, sys%a, st_solve, an%mesh%xy)
      if (is_ok(st_solve)) call multigrid_solve(amg, sys%a, sys%load, sys%kind, sys%bnd, an%u, mset, mres, st_solve)
      call mg_clear(amg)
    else
      call multigrid_solve(an%mg, sys%a, sys%load, sys%kind, sys%bnd, an%u, mset, mres, st_solve)
    end if
    res%primal_iters = mres%iterations
    res%primal_factorisations = mres%galerkin_updates
    res%kkt_residual = mres%kkt_residual
  end subroutine solve_primal_multigrid

  !> A level's tolerance on the part of est its dual solve may leave (est's units): the share
  !> (settings%adapt%algebraic_share on an adaptive step, settings%dual_algebraic_share on a
  !> level of a uniform run) of est predicted for ndof unknowns from the last level or step at
  !> the optimal rate, est ~ 1 / ndof (a slower rate makes the true est larger, so the share
  !> smaller).  0 (solve to the solvers' tolerances) on level 1 and when the last level has
  !> no est.
  pure real(dp) function algebraic_est_tol(an, ndof) result(tol)
    type(analysis_t), intent(in) :: an
    integer, intent(in) :: ndof
    real(dp) :: share
    tol = 0.0_dp
    if (an%level < 2) return
    if (.not. (an%last_est > 0.0_dp) .or. an%last_ndof <= 0 .or. ndof <= 0) return
    share = merge(an%settings%adapt%algebraic_share, an%settings%dual_algebraic_share, an%settings%adapt%enabled)
    tol = share * an%last_est * real(an%last_ndof, dp) / real(ndof, dp)
  end function algebraic_est_tol

  !> An error of a solver becomes the level's error; a warning is recorded in res.
  subroutine take_status(st_step, res, st)
    type(status_t), intent(in) :: st_step
    type(level_result_t), intent(inout) :: res
    type(status_t), intent(inout) :: st
    if (.not. is_ok(st_step)) then
      st = st_step
    else if (st_step%code /= DS_OK) then
      call add_warning(res, st_step%code, st_step%msg)
    end if
  end subroutine take_status

  !> Record a warning of the level.
  subroutine add_warning(res, code, msg)
    type(level_result_t), intent(inout) :: res
    integer, intent(in) :: code
    character(len=*), intent(in) :: msg
    if (res%nwarnings == max_level_warnings) return
    res%nwarnings = res%nwarnings + 1
    res%warnings(res%nwarnings)%code = code
    res%warnings(res%nwarnings)%msg = msg
  end subroutine add_warning

  !> ||u - u_h|| in L2 and in the energy norm of the problem (full H1 norm for P1, H1
  !> seminorm for P2), by quadrature of degree exact_degree.
  subroutine primal_errors(an, res)
    type(analysis_t), intent(in) :: an
    type(level_result_t), intent(inout) :: res
    real(dp) :: err_h1semi
    call p1_error_norms(an%mesh, an%u, an%problem%u_exact, an%problem%grad_exact, an%exact_rule, &
                        res%err_l2, err_h1semi)
    if (an%problem%kind == PROBLEM_P1) then
      res%err_energy = sqrt(res%err_l2**2 + err_h1semi**2)
    else
      res%err_energy = err_h1semi
    end if
    res%has_exact = .true.
  end subroutine primal_errors

  !> The Uzawa tolerance of the level, tied to the discretisation: no point in solving far
  !> below h^2.
  pure real(dp) function dual_tolerance(settings, h, diameter) result(tol)
    type(analysis_settings_t), intent(in) :: settings
    real(dp), intent(in) :: h, diameter
    tol = max(settings%dual_tol, settings%dual_tol_h2 * (h / diameter)**2)
  end function dual_tolerance

  !> P1 (Section 3): the feasible dual field q_h in the space of settings%dual_space
  !> ('hdiv': RT1, 'paper': continuous P1 vector fields), warm-started from u_h by
  !> complementarity, the bounds (6.13), (6.14) and, with an exact solution, the dual errors.
  subroutine dual_level_p1(an, res, st)
    type(analysis_t), intent(inout) :: an
    type(level_result_t), intent(inout) :: res
    type(status_t), intent(inout) :: st
    type(dual_p1_settings_t) :: dset
    type(dual_p1_bounds_t) :: bounds
    type(load_data_t) :: load
    type(status_t) :: st_dual
    real(dp), allocatable :: q(:)
    logical :: hdiv
    hdiv = an%settings%dual_space == 'hdiv'
    dset%method = an%dual_method
    dset%rho = an%settings%dual_rho
    dset%max_iter = an%settings%dual_max_iter
    dset%ordering = an%settings%ordering
    dset%tol = dual_tolerance(an%settings, res%h, mesh_diameter(an%mesh))
    dset%algebraic_share = an%settings%dual_algebraic_share
    dset%algebraic_est_tol = algebraic_est_tol(an, res%ndof)
    res%dual_method = an%dual_method
    res%dual_space = an%settings%dual_space
    ! the load data first (the bounds need it): the RT1 dual takes f from it, exactly
    if (an%settings%bounds) then
      call level_load_data(an, load, res, st)
      if (.not. is_ok(st)) return
    end if
    res%dual_seconds = wall_seconds()
    if (hdiv .and. an%dual_method == 'nested') then
      ! from level 2 on, from the previous level's field (prolongated by analysis_next_level)
      if (an%nest%ready) res%dual_seconds = res%dual_seconds - an%prolong_seconds
      if (an%settings%bounds) then
        call dual_hdiv_solve(an%mesh, an%problem%f, an%load_rule, dset, q, res%dual_p1, st_dual, u_primal=an%u, &
                             nest=an%nest, load=load)
      else
        call dual_hdiv_solve(an%mesh, an%problem%f, an%load_rule, dset, q, res%dual_p1, st_dual, u_primal=an%u, &
                             nest=an%nest)
      end if
    else if (hdiv .and. an%settings%bounds) then
      call dual_hdiv_solve(an%mesh, an%problem%f, an%load_rule, dset, q, res%dual_p1, st_dual, u_primal=an%u, &
                           load=load)
    else if (hdiv) then
      call dual_hdiv_solve(an%mesh, an%problem%f, an%load_rule, dset, q, res%dual_p1, st_dual, u_primal=an%u)
    else
      call dual_p1_solve(an%mesh, an%problem%f, an%load_rule, dset, q, res%dual_p1, st_dual, u_primal=an%u)
    end if
    res%dual_seconds = wall_seconds() - res%dual_seconds
    res%dual_limit = is_warning(st_dual)
    call take_status(st_dual, res, st)
    if (.not. is_ok(st)) return
    res%has_dual = .true.
    res%dual_iters = res%dual_p1%iterations
    if (an%settings%keep_fields) then
      if (hdiv) then
        res%q_hdiv = q
      else
        res%q = q
      end if
    end if
    if (.not. an%settings%bounds) return
    call p1_bounds_level(an, q, load, hdiv, res, bounds, st)
    if (.not. is_ok(st)) return
    res%est = bounds%est
    res%est_hypercircle = bounds%est_hypercircle
    res%energy_lo = bounds%energy_lo
    res%energy_hi = bounds%energy_hi
    call widen_for_rounding(bounds%fu_abs, bounds%uu, bounds%nsum, res)
    call move_alloc(bounds%est_elem, res%est_elem)
    res%certified = res%load_unresolved == 0
    if (an%settings%adapt%enabled) call load_data_move(load, an%load_keep)   ! for the next step
  end subroutine dual_level_p1

  !> The bounds of P1 from the load data and, with an exact solution, the dual errors: for
  !> the RT1 field q (hdiv) or the continuous field of Section 3.
  subroutine p1_bounds_level(an, q, load, hdiv, res, bounds, st)
    type(analysis_t), intent(in) :: an
    real(dp), intent(in) :: q(:)
    type(load_data_t), intent(in) :: load
    logical, intent(in) :: hdiv
    type(level_result_t), intent(inout) :: res
    type(dual_p1_bounds_t), intent(out) :: bounds
    type(status_t), intent(inout) :: st         !! kept (a warning) unless out of memory
    real(dp), allocatable :: breaks(:)
    type(status_t) :: st_bounds
    real(dp) :: t0
    if (hdiv) then
      call dual_hdiv_bounds_load(an%mesh, an%u, q, load, bounds, st_bounds)
    else
      call dual_p1_bounds_load(an%mesh, an%u, q, load, bounds, st_bounds)
    end if
    if (is_error(st_bounds)) then
      st = st_bounds
      return
    end if
    if (.not. res%has_exact) return
    t0 = wall_seconds()
    associate (pb => an%problem)
      if (allocated(pb%x_breaks)) then
        breaks = pb%x_breaks
      else
        allocate (breaks(0))                      ! small: empty
      end if
      if (hdiv) then
        call dual_hdiv_errors(an%mesh, q, pb%f, pb%u_exact, pb%grad_exact, an%exact_rule, res%err_q, res%err_div, &
                              res%err_q_norm, breaks)
      else
        call dual_p1_errors(an%mesh, q, pb%f, pb%u_exact, pb%grad_exact, an%exact_rule, res%err_q, res%err_div, &
                            res%err_q_norm, breaks)
      end if
    end associate
    res%verify_seconds = res%verify_seconds + (wall_seconds() - t0)
  end subroutine p1_bounds_level

  !> The load data of the level (dualsig_load_data: per-triangle mean, moments and
  !> oscillation of f, integrated until converged); triangles where they did not converge
  !> are counted in res (the bounds are then not certified) and reported as a warning.
  subroutine level_load_data(an, load, res, st)
    type(analysis_t), intent(inout) :: an
    type(load_data_t), intent(out) :: load
    type(level_result_t), intent(inout) :: res
    type(status_t), intent(inout) :: st
    real(dp), allocatable :: breaks(:)
    if (allocated(an%problem%x_breaks)) then
      breaks = an%problem%x_breaks
    else
      allocate (breaks(0))                      ! small: empty
    end if
    if (allocated(an%tri_origin) .and. allocated(an%load_keep%mean)) then
      ! an adaptive step: the triangles left whole keep the last step's data
      call load_data_build(an%mesh, an%problem%f, load, st, breaks, prev=an%load_keep, origin=an%tri_origin)
    else
      call load_data_build(an%mesh, an%problem%f, load, st, breaks)
    end if
    an%load_keep = load_data_t()
    if (allocated(an%tri_origin)) deallocate (an%tri_origin)
    if (.not. is_ok(st)) return
    res%load_unresolved = load%nunconverged
    if (load%nunconverged > 0 .and. load%budget_spent) then
      call add_warning(res, DS_WARN_NOT_CERTIFIED, 'the integrals of f did not converge on ' // &
        itoa(load%nunconverged) // ' triangle(s): the cubature spent its budget of evaluations (f varies ' // &
        'faster than its rules resolve there: a smooth f needs triangles of about half the length on which ' // &
        'it changes, e.g. 2 per period of an oscillation, to be certified; unless f is singular there, as ' // &
        '1/(x - c), or its values are rounding noise, as on a domain far from the origin for its size: ' // &
        'then no mesh certifies it)' // guard_note(load) // ': the bounds are NOT certified')
    else if (load%nunconverged > 0) then
      call add_warning(res, DS_WARN_NOT_CERTIFIED, 'the integrals of f did not converge on ' // &
        itoa(load%nunconverged) // ' triangle(s) (f jumps or varies below the resolution of the cubature' // &
        guard_note(load) // '): the bounds are NOT certified')
    end if
  end subroutine level_load_data

  !> '; its enclosure ...' when the load data's interval check found f with values its
  !> cubature points did not show (load_data_t%nguarded), else ''.
  function guard_note(load) result(note)
    type(load_data_t), intent(in) :: load
    character(len=:), allocatable :: note
    note = ''
    if (load%nguarded > 0) note = '; on ' // itoa(load%nguarded) // ' piece(s) the interval enclosure of f ' // &
      'reaches values its cubature points do not show: a strip or spike between them, or a jump (declare ' // &
      'its line in &problem breaks or use a mesh that resolves it), or an enclosure that interval arithmetic ' // &
      'overestimates where f varies fast (a finer mesh narrows it)'
  end function guard_note

  !> The P2 dual field of the level by dual_p2_solve with the settings dset (the kinks of f
  !> passed when the problem has them).
  subroutine solve_p2_field(an, dset, is_gamma_a, load, field, res, st_dual)
    type(analysis_t), intent(inout) :: an
    type(dual_p2_settings_t), intent(in) :: dset
    logical, intent(in) :: is_gamma_a(:)
    type(load_data_t), intent(in) :: load
    type(dual_p2_field_t), intent(out) :: field
    type(level_result_t), intent(inout) :: res
    type(status_t), intent(out) :: st_dual
    associate (pb => an%problem, mesh => an%mesh)
      if (allocated(pb%x_breaks)) then
        call dual_p2_solve(mesh, pb%f, is_gamma_a, minval(mesh%xy(1, :)), dset, field, res%dual_p2, st_dual, &
                           pb%x_breaks, an%u, load=load, mg=an%mg, psi=an%psi, active_set=an%psi_set, flux_f=an%flux_f)
      else
        call dual_p2_solve(mesh, pb%f, is_gamma_a, minval(mesh%xy(1, :)), dset, field, res%dual_p2, st_dual, &
                           u_primal=an%u, load=load, mg=an%mg, psi=an%psi, active_set=an%psi_set, flux_f=an%flux_f)
      end if
    end associate
  end subroutine solve_p2_field

  !> The P2 dual method of 'default' on this level: 'multigrid' (the stream function, O(N),
  !> no factorisation) on simply connected domains with the polynomial lambda^f, either on
  !> the grids of the uniform refinements when they reach this mesh (level 2 on of a uniform
  !> run, whatever the primal method) or, on a mesh without them (level 1, Gmsh meshes,
  !> adaptive steps), from mg_auto_min_unknowns nodes on, on the P1 grid of the mesh with
  !> smoothed aggregation below it (7-20 V-cycles a step on data/adapt_lshape.nml, 5.5 s
  !> and 377 MB against 9.0 s and 997 MB); 'augmented' otherwise (small one-level meshes,
  !> where the factorisation costs as much, and domains with holes).  A failed or stalled
  !> stream-function solve falls back on 'augmented' (dual_level_p2).
  function p2_dual_choice(an) result(method)
    type(analysis_t), intent(in) :: an
    character(len=16) :: method
    logical :: grids
    method = 'augmented'
    if (an%mesh%nloop /= 1 .or. an%settings%dual_particular /= 'polynomial') return
    grids = an%mg%nlevel >= 2 .and. mg_finest_size(an%mg) == an%mesh%nnode
    if (grids .or. an%mesh%nnode >= mg_auto_min_unknowns) method = 'multigrid'
  end function p2_dual_choice

  !> P2 (Sections 4-6): the admissible field lambda_h = lambda^f + q_h by equilibrium
  !> elements (warm-started from u_h), the bounds (6.26) and Theorem 6.4 and, with an exact
  !> solution, ||grad u - lambda_h||.  A divergence defect above admissible_defect is a
  !> warning (DS_WARN_NOT_CERTIFIED) and the level is not certified.
  subroutine dual_level_p2(an, res, st)
    type(analysis_t), intent(inout) :: an
    type(level_result_t), intent(inout) :: res
    type(status_t), intent(inout) :: st
    type(dual_p2_settings_t) :: dset
    type(dual_p2_bounds_t) :: bounds
    type(dual_p2_field_t) :: field
    type(load_data_t) :: load
    type(status_t) :: st_dual
    logical, allocatable :: is_gamma_a(:)
    integer :: j, ist
    real(dp) :: t0
    allocate (is_gamma_a(an%mesh%nbedge), stat=ist)
    if (alloc_failed(ist, st, 'the Gamma_a flags', an%mesh%nbedge, BYTES_LOGICAL)) return
    do j = 1, an%mesh%nbedge
      is_gamma_a(j) = any(an%problem%gamma_a == an%mesh%bedge_marker(j))
    end do
    dset%method = an%dual_method
    if (dset%method == 'auto') dset%method = p2_dual_choice(an)
    dset%rho = an%settings%dual_rho
    dset%max_iter = an%settings%dual_max_iter
    dset%ordering = an%settings%ordering
    dset%penalty = an%settings%dual_penalty
    dset%inner = an%settings%dual_inner
    dset%tol = dual_tolerance(an%settings, res%h, mesh_diameter(an%mesh))
    dset%particular = an%settings%dual_particular
    dset%est_tol = algebraic_est_tol(an, res%ndof)
    ! the last level of a uniform run: its stream function joins no later level, so sweeps
    ! from the previous level's psi may stand for the multigrid when they reach est_tol
    if (an%level >= an%settings%levels .and. .not. an%settings%adapt%enabled) dset%smooth_sweeps = p2_last_sweeps
    res%dual_method = dset%method
    if (dset%particular == 'polynomial') then
      call level_load_data(an, load, res, st)
      if (.not. is_ok(st)) return
    end if
    associate (pb => an%problem, mesh => an%mesh)
      res%dual_seconds = wall_seconds()
      call solve_p2_field(an, dset, is_gamma_a, load, field, res, st_dual)
      if (an%dual_method == 'auto' .and. dset%method == 'multigrid' .and. st_dual%code /= DS_OK) then
        ! 'default' falls back on the factorisation when the stream function's solve fails or
        ! stalls (needle triangles: Gauss-Seidel does not smooth there)
        dset%method = 'augmented'
        res%dual_method = dset%method
        call solve_p2_field(an, dset, is_gamma_a, load, field, res, st_dual)
      end if
      res%dual_seconds = wall_seconds() - res%dual_seconds
      res%dual_limit = is_warning(st_dual)
      call take_status(st_dual, res, st)
      if (.not. is_ok(st)) return
      res%has_dual = .true.
      res%dual_iters = res%dual_p2%iterations
      res%certified = res%dual_p2%defect <= an%settings%admissible_defect
      if (.not. res%certified) call add_warning(res, DS_WARN_NOT_CERTIFIED, &
        'the dual field has a divergence defect above the admissible one: lambda_h is not admissible and est, ' // &
        'energy_hi are NOT guaranteed bounds')
      if (.not. res%dual_p2%particular_converged) then
        res%certified = .false.
        call add_warning(res, DS_WARN_NOT_CERTIFIED, 'a line integral of the particular field did not converge: ' // &
          'est, energy_hi are NOT guaranteed bounds')
      end if
      if (res%load_unresolved > 0) res%certified = .false.
      if (.not. field%polynomial .and. res%certified) then
        ! the paper's lambda^f: its integrals are quadratures of non-polynomials, not checked
        res%certified = .false.
        call add_warning(res, DS_WARN_NOT_CERTIFIED, 'the particular field is the paper''s lambda_bar + curl ' // &
          'omega (&dual particular = ''stream''): the bounds rest on quadrature and are not certified')
      end if
      if (an%settings%keep_fields) res%lambda = field
      if (.not. an%settings%bounds) return
      if (field%polynomial) then
        call dual_p2_bounds_load(mesh, an%u, field, load, is_gamma_a, bounds, st_dual)
        res%oscillation = bounds%oscillation
      else
        call dual_p2_bounds(mesh, an%u, field, pb%f, is_gamma_a, an%bound_rule_p2, bounds, st_dual)
      end if
      if (is_error(st_dual)) then
        st = st_dual
        return
      end if
      if (res%has_exact) then
        t0 = wall_seconds()
        res%err_q = dual_p2_error(mesh, field, pb%f, pb%grad_exact, an%bound_rule_p2)
        res%verify_seconds = res%verify_seconds + (wall_seconds() - t0)
      end if
    end associate
    res%est = bounds%est
    res%est_hypercircle = bounds%est
    res%energy_lo = bounds%energy_lo
    res%energy_hi = bounds%energy_hi
    call widen_for_rounding(bounds%fu_abs, bounds%uu, bounds%nsum, res)
    call move_alloc(bounds%est_elem, res%est_elem)
    if (an%settings%adapt%enabled .and. allocated(load%mean)) call load_data_move(load, an%load_keep)
  end subroutine dual_level_p2

  !> The energy bracket widened by the rounding of its sums.  Each sum is summed per triangle
  !> (at most m terms) and then over the ntri triangles: it is within (ntri + m) u sum |terms|
  !> of the exact sum (u = epsilon/2, recursive summation), and each term within a few
  !> dozen roundings of its value.  energy_lo = 2 (f, u~) - ||u~||_1^2 and energy_hi (F(q),
  !> ||lambda||^2 or one of their sharper forms, built from these sums and est) move apart by
  !>     delta = (nsum + rounding_ops_per_term) epsilon (2 fu_abs + uu + |energy_hi| + est_hypercircle),
  !> nsum = ntri + m, fu_abs = sum |terms of (f, u~)|, uu = ||u~||_1^2 (the other sums have
  !> terms of one sign, so their value is the sum of their absolute values).
  !> Without it a solution that the mesh represents exactly (u = 1 for P1 with f = 1) gave
  !> energy_hi below the energy by 3e-12 (seventh review, M1).  est is not widened: it is a
  !> sum of nonnegative terms, exact to a relative n u.
  pure subroutine widen_for_rounding(fu_abs, uu, nsum, res)
    real(dp), intent(in) :: fu_abs, uu
    integer, intent(in) :: nsum
    type(level_result_t), intent(inout) :: res
    real(dp) :: delta
    delta = real(nsum + rounding_ops_per_term, dp) * epsilon(1.0_dp) * &
            (2.0_dp * fu_abs + abs(uu) + abs(res%energy_hi) + abs(res%est_hypercircle))
    res%energy_lo = res%energy_lo - delta
    res%energy_hi = res%energy_hi + delta
  end subroutine widen_for_rounding
end module dualsig_analysis
