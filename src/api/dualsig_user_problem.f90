!> One's own problem from the namelist group &problem: the kind, the load (an expression in
!> x and y; an expression per region of the coarse mesh; or nodal values on the coarse mesh
!> read from a file), the optional exact solution u (its gradient by automatic
!> differentiation of the same expression) and the abscissae where f jumps or kinks.
!>
!> The expressions were compiled (and syntax errors reported) when the namelist was read;
!> here they are compiled again for the fields and checked at the nodes and centroids of
!> the coarse mesh: a value that is not finite (NaN, Inf) is an error naming the file, the
!> variable, the point and the triangle.  Boundary parts are the driver's (&run).
module dualsig_user_problem
  use dualsig_kinds, only: dp, i8
  use dualsig_status, only: status_t, set_error, is_ok, DS_ERR_INPUT, DS_ERR_IO
  use dualsig_strings, only: itoa, i8toa, rtoa, distinct_text
  use dualsig_problem_kinds, only: PROBLEM_P1, PROBLEM_P2
  use dualsig_expression, only: expression_t, expression_compile, expression_check_finite, &
                                expression_input_message
  use dualsig_mesh, only: mesh_t
  use dualsig_expression_fields, only: expression_field, expression_gradient
  use dualsig_coarse_fields, only: region_field, nodal_field, region_field_t, nodal_field_t
  use dualsig_mesh_gmsh, only: gmsh_physical_t
  use dualsig_io_config, only: run_config_t, config_text
  use dualsig_analysis, only: analysis_problem_t
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use dualsig_alloc, only: alloc_failed, BYTES_REAL, BYTES_INT
  use dualsig_io_files, only: input_file_ok
  implicit none
  private

  !> An f_file larger than f_file_fixed_bytes + f_file_bytes_per_node per node of the coarse
  !> mesh is refused before it is read (values and comments of a text file need far less;
  !> a binary file given by mistake would be read as one huge line).
  integer(i8), parameter :: f_file_fixed_bytes = 1048576_i8, f_file_bytes_per_node = 256_i8
  !> Characters of a bad field shown in the message.
  integer, parameter :: shown_chars = 40

  public :: user_problem_build, user_problem_description

  !> Longest expression shown in the table header (longer ones end in '...').
  integer, parameter :: shown_len = 160

contains

  !> The kind, load, exact solution and breaks of &problem into pb (whose coarse mesh is
  !> read).  `phys`: the physical names of a Gmsh mesh (for region names).
  subroutine user_problem_build(cfg, phys, pb, st)
    type(run_config_t), intent(in) :: cfg
    type(gmsh_physical_t), intent(in) :: phys
    type(analysis_problem_t), intent(inout) :: pb
    type(status_t), intent(out) :: st
    type(expression_t) :: e
    pb%kind = merge(PROBLEM_P1, PROBLEM_P2, cfg%problem_kind == 'P1')
    if (len_trim(config_text(cfg%f)) > 0) then
      call checked_expression(cfg, 'f', trim(config_text(cfg%f)), pb%mesh, .false., e, st)
      if (st%code /= 0) return
      allocate (pb%f, source=expression_field(e))       ! small: a compiled expression
    else if (any(cfg%f_regions /= '')) then
      call region_load(cfg, phys, pb, st)
    else
      call file_load(cfg, pb, st)
    end if
    if (st%code /= 0) return
    if (len_trim(config_text(cfg%u_exact)) > 0) then
      call checked_expression(cfg, 'u_exact', trim(config_text(cfg%u_exact)), pb%mesh, .true., e, st)
      if (st%code /= 0) return
      allocate (pb%u_exact, source=expression_field(e))        ! small: a compiled expression
      allocate (pb%grad_exact, source=expression_gradient(e))  ! small: a compiled expression
    end if
    pb%x_breaks = cfg%breaks(1:cfg%nbreaks)
  end subroutine user_problem_build

  !> What was solved, for the table header: 'P2, f = ...' (long expressions cut).
  function user_problem_description(cfg) result(s)
    type(run_config_t), intent(in) :: cfg
    character(len=:), allocatable :: s
    integer :: k
    s = trim(cfg%problem_kind) // ', f = '
    if (len_trim(config_text(cfg%f)) > 0) then
      s = s // shown(trim(config_text(cfg%f)))
    else if (any(cfg%f_regions /= '')) then
      s = s // 'per region:'
      do k = 1, size(cfg%f_regions)
        if (cfg%f_regions(k) == '') cycle
        s = s // ' ' // trim(cfg%f_regions(k)) // ': ' // shown(trim(cfg%f_region_values(k))) // ';'
      end do
      s = s(1:len(s) - 1)
    else
      s = s // 'the P1 interpolant of the nodal values in ' // trim(config_text(cfg%f_file))
    end if
    if (len_trim(config_text(cfg%u_exact)) > 0) s = s // ', u_exact = ' // shown(trim(config_text(cfg%u_exact)))
    if (cfg%nbreaks > 0) then
      s = s // ', breaks at x ='
      do k = 1, cfg%nbreaks
        s = s // ' ' // rtoa(cfg%breaks(k))
      end do
    end if
  contains
    function shown(text) result(t)
      character(len=*), intent(in) :: text
      character(len=:), allocatable :: t
      if (len(text) > shown_len) then
        t = text(1:shown_len - 3) // '...'
      else
        t = text
      end if
    end function shown
  end function user_problem_description

  !> The namelist file and the line of the run (a batch has several), for the messages.
  function run_of(cfg) result(where)
    type(run_config_t), intent(in) :: cfg
    character(len=:), allocatable :: where
    where = cfg%source_file // ': run of line ' // itoa(cfg%line)
  end function run_of

  !> Compile `text` (the value of &problem `variable`) and check it, and its gradient when
  !> `gradient`, at the nodes and centroids of the coarse triangles (those with mask, when
  !> given).
  subroutine checked_expression(cfg, variable, text, mesh, gradient, e, st, mask)
    type(run_config_t), intent(in) :: cfg
    character(len=*), intent(in) :: variable, text
    type(mesh_t), intent(in) :: mesh
    logical, intent(in) :: gradient
    type(expression_t), intent(out) :: e
    type(status_t), intent(out) :: st
    logical, intent(in), optional :: mask(:)
    real(dp), allocatable :: x(:), y(:)
    integer, allocatable :: owner(:)
    real(dp) :: c(2)
    integer :: t, k, i, n, ist
    logical :: ok
    call expression_compile(text, e, st)
    if (st%code /= 0) then
      st%msg = expression_input_message(run_of(cfg), 'problem', variable, text, st%msg)
      return
    end if
    ! the points: per triangle its centroid and its vertices (a triangle's own, so that a
    ! region's expression is checked on its region only)
    allocate (x(4 * mesh%ntri), y(4 * mesh%ntri), owner(4 * mesh%ntri), stat=ist)
    if (alloc_failed(ist, st, 'the points to check an expression at', 12 * mesh%ntri, BYTES_REAL)) return
    n = 0
    do t = 1, mesh%ntri
      if (present(mask)) then
        if (.not. mask(t)) cycle
      end if
      c = sum(mesh%xy(:, mesh%tri(:, t)), dim=2) / 3.0_dp
      n = n + 1
      x(n) = c(1)
      y(n) = c(2)
      owner(n) = t
      do k = 1, 3
        n = n + 1
        x(n) = mesh%xy(1, mesh%tri(k, t))
        y(n) = mesh%xy(2, mesh%tri(k, t))
        owner(n) = t
      end do
    end do
    call expression_check_finite(e, x(1:n), y(1:n), ok, i, gradient, st)
    if (ok .or. .not. is_ok(st)) return
    t = owner(i)
    call set_error(st, DS_ERR_INPUT, expression_input_message(run_of(cfg), 'problem', variable, text, &
      trim(merge('the value or its gradient', 'the value                ', gradient)) // ' is not finite (NaN or Inf) at ' // &
      '(' // rtoa(x(i)) // ', ' // rtoa(y(i)) // '), ' // &
      trim(merge('the centroid of', 'a vertex of    ', mod(i - 1, 4) == 0)) // ' triangle ' // itoa(t) // &
      ' of the coarse mesh (expected finite values at the nodes and centroids of the mesh)'))
  end subroutine checked_expression

  !> f per region: each region named (a Gmsh physical surface name, or a tag: a Gmsh
  !> physical surface tag, a Triangle region attribute) takes its expression.
  subroutine region_load(cfg, phys, pb, st)
    type(run_config_t), intent(in) :: cfg
    type(gmsh_physical_t), intent(in) :: phys
    type(analysis_problem_t), intent(inout) :: pb
    type(status_t), intent(out) :: st
    type(expression_t), allocatable :: exprs(:)
    integer, allocatable :: tags(:), tri_expr(:)
    integer :: k, n, t, j, ios, ist
    type(region_field_t) :: rf
    character(len=:), allocatable :: where, item
    where = cfg%source_file // ': run of line ' // itoa(cfg%line) // ': '
    if (.not. allocated(pb%mesh%tri_region)) then
      call set_error(st, DS_ERR_INPUT, where // '&problem f_regions: the mesh has no regions (expected a Gmsh ' // &
        'mesh with physical surfaces, or a Triangle mesh whose triangles carry integer region attributes)')
      return
    end if
    n = count(cfg%f_regions /= '')
    allocate (exprs(n), tags(n), tri_expr(pb%mesh%ntri), stat=ist)
    if (alloc_failed(ist, st, 'the regions of the triangles', pb%mesh%ntri, BYTES_INT)) return
    n = 0
    do k = 1, size(cfg%f_regions)
      if (cfg%f_regions(k) == '') cycle
      n = n + 1
      read (cfg%f_regions(k), *, iostat=ios) tags(n)
      if (ios /= 0 .or. verify(trim(adjustl(cfg%f_regions(k))), '+-0123456789') > 0) then
        j = 0
        if (allocated(phys%name)) j = findloc(phys%name == cfg%f_regions(k) .and. phys%dim == 2, .true., dim=1)
        if (j == 0) then
          call set_error(st, DS_ERR_INPUT, where // '&problem f_regions: no region ''' // trim(cfg%f_regions(k)) // &
            ''' in the mesh (expected a Gmsh physical surface name' // surface_names(phys) // ', or a region tag: ' // &
            distinct_text(pb%mesh%tri_region) // ')')
          return
        end if
        tags(n) = phys%tag(j)
      end if
      if (count(tags(1:n) == tags(n)) > 1) then
        call set_error(st, DS_ERR_INPUT, where // '&problem f_regions: region ''' // trim(cfg%f_regions(k)) // &
          ''' (tag ' // itoa(tags(n)) // ') is given twice (expected each region once)')
        return
      end if
    end do
    tri_expr = 0
    do t = 1, pb%mesh%ntri
      j = findloc(tags, pb%mesh%tri_region(t), dim=1)
      if (j == 0) then
        call set_error(st, DS_ERR_INPUT, where // '&problem f_regions: triangle ' // itoa(t) // ' of the mesh lies ' // &
          'in region ' // itoa(pb%mesh%tri_region(t)) // ', which has no value (expected a value for every region ' // &
          'of the mesh: ' // distinct_text(pb%mesh%tri_region) // ')')
        return
      end if
      tri_expr(t) = j
    end do
    n = 0
    do k = 1, size(cfg%f_regions)
      if (cfg%f_regions(k) == '') cycle
      n = n + 1
      item = 'f_region_values(' // itoa(k) // ')'
      call checked_expression(cfg, item, trim(cfg%f_region_values(k)), pb%mesh, .false., exprs(n), st, &
                              mask=tri_expr == n)
      if (st%code /= 0) return
    end do
    rf = region_field(pb%mesh, tri_expr, exprs, st)
    if (.not. is_ok(st)) return
    allocate (pb%f, source=rf, stat=ist)
    if (alloc_failed(ist, st, 'the load of the regions', 4 * pb%mesh%ntri + 2 * pb%mesh%nnode, BYTES_REAL)) return
  end subroutine region_load

  !> The names of the physical surfaces, as '; its surfaces: 'a', 'b'' (or '').
  function surface_names(phys) result(s)
    type(gmsh_physical_t), intent(in) :: phys
    character(len=:), allocatable :: s
    integer :: j
    s = ''
    if (.not. allocated(phys%name)) return
    do j = 1, size(phys%name)
      if (phys%dim(j) /= 2) cycle
      if (len(s) > 0) s = s // ', '
      s = s // '''' // trim(phys%name(j)) // ''''
    end do
    if (len(s) > 0) s = ' (' // s // ')'
  end function surface_names

  !> f from nodal values: the file holds one value per node of the coarse mesh, in node
  !> order, separated by blanks or line ends; '#' and '!' start comments.
  subroutine file_load(cfg, pb, st)
    type(run_config_t), intent(in) :: cfg
    type(analysis_problem_t), intent(inout) :: pb
    type(status_t), intent(out) :: st
    real(dp), allocatable :: values(:)
    character(len=:), allocatable :: path, where
    character(len=4096) :: line
    character(len=256) :: msg
    integer :: u, ios, n, lineno, k, p, q, nn, ist
    integer(i8) :: nbytes
    real(dp) :: v
    type(nodal_field_t) :: nf
    path = trim(config_text(cfg%f_file))
    where = cfg%source_file // ': run of line ' // itoa(cfg%line) // ': &problem f_file = ''' // path // ''': '
    nn = pb%mesh%nnode
    ! stat(2) first: a FIFO would block the open, a device (/dev/zero) never ends, a
    ! directory holds no values; a file far larger than nn values need (a binary file given
    ! by mistake) would be read as one huge line
    if (.not. input_file_ok(path, where, 'a text file of nodal values', nbytes, st)) return
    if (nbytes > f_file_fixed_bytes + f_file_bytes_per_node * int(nn, i8)) then
      call set_error(st, DS_ERR_INPUT, where // i8toa(nbytes) // ' bytes, more than a text file of ' // &
        itoa(nn) // ' nodal values plausibly holds (at most ' // &
        i8toa(f_file_fixed_bytes + f_file_bytes_per_node * int(nn, i8)) // &
        '; expected one value per node of the coarse mesh)')
      return
    end if
    open (newunit=u, file=path, status='old', action='read', iostat=ios, iomsg=msg)
    if (ios /= 0) then
      call set_error(st, DS_ERR_IO, where // 'cannot open for reading (' // trim(msg) // &
        '); expected a readable file of nodal values')
      return
    end if
    allocate (values(nn), stat=ist)
    if (alloc_failed(ist, st, 'the nodal values of f', nn, BYTES_REAL)) then
      close (u)
      return
    end if
    n = 0
    lineno = 0
    do
      read (u, '(a)', iostat=ios) line
      if (ios /= 0) exit
      lineno = lineno + 1
      k = scan(line, '#!')
      if (k > 0) line(k:) = ' '
      p = 1
      do                                          ! the blank-separated fields of the line
        if (p > len_trim(line)) exit
        k = verify(line(p:), ' ' // achar(9) // ',')
        if (k == 0) exit
        p = p + k - 1
        q = scan(line(p:), ' ' // achar(9) // ',')
        q = merge(len_trim(line), p + q - 2, q == 0)
        read (line(p:q), *, iostat=ios) v
        if (ios /= 0 .or. .not. ieee_is_finite(v)) then
          call set_error(st, DS_ERR_INPUT, where // 'line ' // itoa(lineno) // ': ''' // &
            printable(line(p:min(q, p + shown_chars - 1))) // trim(merge('...', '   ', q > p + shown_chars - 1)) // &
            ''' is not a finite real number (expected one value per node of the coarse mesh)')
          close (u)
          return
        end if
        n = n + 1
        if (n <= nn) values(n) = v
        p = q + 1
      end do
    end do
    close (u)
    if (n /= nn) then
      call set_error(st, DS_ERR_INPUT, where // 'holds ' // itoa(n) // ' values but the coarse mesh has ' // &
        itoa(nn) // ' nodes (expected one value per node, in the node order of the mesh)')
      return
    end if
    nf = nodal_field(pb%mesh, values, st)
    if (.not. is_ok(st)) return
    allocate (pb%f, source=nf, stat=ist)
    if (alloc_failed(ist, st, 'the nodal load', 3 * pb%mesh%nnode + 3 * pb%mesh%ntri, BYTES_REAL)) return
  end subroutine file_load

  !> s with every character outside printable ASCII replaced by '?' (for messages).
  pure function printable(s) result(t)
    character(len=*), intent(in) :: s
    character(len=len(s)) :: t
    integer :: i
    do i = 1, len(s)
      t(i:i) = s(i:i)
      if (iachar(s(i:i)) < 32 .or. iachar(s(i:i)) > 126) t(i:i) = '?'
    end do
  end function printable

end module dualsig_user_problem
