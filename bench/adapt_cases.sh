# The cases of issue 14's work-precision studies and the namelist they run with; sourced by
# bench/adapt_work_precision.sh and bench/adapt_at_uniform_error.sh (not run on its own).
# MIN_GROWTH, ALGEBRAIC_SHARE: see bench/adapt_work_precision.sh; MAX_SECONDS: &adapt max_seconds
# of the adaptive runs (default 300).
# case: name scene gamma_u gamma_a mesh-group adapt-tol adapt-max-ndof
# scene: a scene's name, or f=<expression> for a P2 &problem with that load (no scene);
# a mesh file is named relative to out/wp/, where the namelists are written.
cases=(
  "lshape_dirichlet_corner|p2_lshape_corner|2, 3|1, 4, 5, 6|source = 'lshape', n = 1|1.0e-3|300000"
  "lshape_transition|p2_lshape_load|4, 5, 6|1, 2, 3|source = 'lshape', n = 1|1.0e-3|300000"
  "square_smooth|p2_contact|2, 3, 4|1|source = 'rectangle', nx = 2, ny = 2|1.0e-3|300000"
  "notch_transition|f=10*y|1, 2, 3, 4|5, 6|source = 'file', file = '../../data/notch_square.mesh'|1.0e-3|300000"
)
namelist() {  # name scene gu ga mesh levels [adapt tol ndof]
  local scene_item="scene = '$2', "
  [[ $2 == f=* ]] && scene_item=''
  cat <<NML
&run
  title = '$1', ${scene_item}output = 'out/wp/$1_run'
  gamma_u_markers = $3
  gamma_a_markers = $4
/
&mesh
  $5, levels = $6
/
&dual
  enabled = .true.
/
NML
  if [[ $2 == f=* ]]; then
    printf "&problem\n  kind = 'P2', f = '%s'\n/\n" "${2#f=}"
  fi
  if [ $# -gt 6 ]; then
    printf '&adapt\n  enabled = .true., tol = %s, max_ndof = %s, max_seconds = %s%s%s\n/\n' "$7" "$8" "${MAX_SECONDS:-300}" \
      "${MIN_GROWTH:+, min_growth = $MIN_GROWTH}" "${ALGEBRAIC_SHARE:+, algebraic_share = $ALGEBRAIC_SHARE}"
  fi
}
