"""Type stubs generated from the settings schema by python/gen_stubs.py; do not edit."""
from os import PathLike as _PathLike
from typing import Any, Callable, Literal, Mapping, Sequence

import numpy as np

from .errors import GeometryError, InputError, SettingError, TrellisError, TrellisWarning

PathLike = str | _PathLike[str]
Machine = PathLike | Mapping[str, Mapping[str, Any]]
Progress = Callable[[str, float], None]

__version__: str
ROLES: list[str]

class Lattice:
    nodes: np.ndarray
    edges: np.ndarray
    material: np.ndarray
    node_count: int
    edge_count: int
    total_length: float
    @staticmethod
    def from_arrays(nodes: Any, edges: Any, material: Any = None) -> Lattice: ...
    def write(self, path: PathLike) -> None: ...
    def to_json(self) -> str: ...

class Toolpath:
    points: np.ndarray
    path_offsets: np.ndarray
    layer_offsets: np.ndarray
    layer_z: np.ndarray
    role: np.ndarray
    tool: np.ndarray
    width: np.ndarray
    height: np.ndarray
    speed: np.ndarray
    power: np.ndarray
    temperature: np.ndarray
    mixture: np.ndarray
    layer_count: int
    path_count: int
    point_count: int
    extrusion_length: float
    lasers: list[dict[str, float | bool]]
    @staticmethod
    def from_arrays(points: Any, path_offsets: Any = None, layer_offsets: Any = None, *, layer_z: Any = None,
                    role: Any = 'strut', tool: Any = 0, width: Any = 0.0, height: Any = 0.0, speed: Any = 0.0,
                    power: Any = 0.0, temperature: Any = 0.0, mixture: Any = None) -> Toolpath: ...
    def arrays(self) -> dict[str, np.ndarray]: ...
    def path(self, i: int) -> np.ndarray: ...
    def to_json(self) -> str: ...
    def gcode(self, machine: Machine | None = None, set: Mapping[str, Any] | None = None) -> str: ...
    def cli(self, machine: Machine | None = None, set: Mapping[str, Any] | None = None, binary: bool = False) -> bytes: ...
    def png(self, layer: int = 0, size: int = 600) -> bytes: ...
    def view_html(self, title: str | None = None) -> str: ...
    def save_view(self, path: PathLike, title: str | None = None) -> None: ...
    def view_notebook(self, title: str | None = None) -> str: ...

class Result:
    files: list[str]
    summary: str
    warnings: list[tuple[str, str]]
    exit_code: int
    toolpath: Toolpath | None
    lattice: Lattice | None

def lattice2d(
    output: PathLike | None = None, *, preview: PathLike | None = None,
    progress: Progress | None = None,
    set: Mapping[str, Any] | None = None,
    arrowhead_inner: float = ...,  # lattice2d.arrowhead_inner: arrowhead: inner chevron angle
    arrowhead_outer: float = ...,  # lattice2d.arrowhead_outer: arrowhead: outer chevron angle
    cell: float = ...,  # lattice2d.cell: cell size: hexagon side, rhombus side, edge or period (see lattice2d --help)
    cell_height: float = ...,  # lattice2d.cell_height: arrowhead and re-entrant honeycomb: the unit cell's vertical length (the cell size is the horizontal one, GIPPO Table 1); sets the arrowhead's i
    contour: bool = ...,  # lattice2d.contour: add the region outline as struts
    density: float = ...,  # lattice2d.density: Voronoi seeds per mm²
    diameter: float = ...,  # lattice2d.diameter: circle diameter
    follow_symlinks: bool = ...,  # run.follow_symlinks: write an output whose path is a symbolic link to the file it points to (the link kept); without it such an output is refused
    force: bool = ...,  # run.force: run even when the estimate is beyond run.max_memory or run.max_time
    frames: int = ...,  # output.frames: aero: step pictures of the first N trails
    handle_length: float = ...,  # lattice2d.handle_length: handle length along x
    handle_width: float = ...,  # lattice2d.handle_width: handle width along y
    handles: bool = ...,  # lattice2d.handles: tensile-test handles at both x ends
    image_size: int = ...,  # output.image_size: preview image size
    line_width: float = ...,  # lattice2d.line_width: printed line width for the reported pore area
    max_memory: float = ...,  # run.max_memory: refuse a run whose estimate (made from its settings before it starts) needs more memory than this
    max_time: float = ...,  # run.max_time: refuse a run whose estimated time is longer than this
    pattern: Literal['honeycomb', 'voronoi', 'penrose', 'snub-square', 'arrowhead', 'reentrant-honeycomb', 'square', 'triangle', 'lines'] = ...,  # lattice2d.pattern: atlas pattern
    reentrant_angle: float = ...,  # lattice2d.reentrant_angle: re-entrant honeycomb: strut angle below horizontal
    region: Literal['rectangle', 'circle'] = ...,  # lattice2d.region: crop region
    region_center: Sequence[float] = ...,  # lattice2d.center: region centre x, y
    ring_spacing: float = ...,  # lattice2d.ring_spacing: distance between clamping rings (two or more)
    rings: int = ...,  # lattice2d.rings: clamping rings: concentric outlines at the region's rim, the pattern inside the innermost (GIPPO's Ø48 ball-burst discs); 0 = none
    rotation: float = ...,  # lattice2d.rotation: pattern rotation about the region centre
    seed: int = ...,  # lattice2d.seed: Voronoi random seed
    size: Sequence[float] = ...,  # lattice2d.size: rectangle width, height
    strand: float = ...,  # lattice2d.strand: strand distance of square, triangle and lines
    target_porosity: float = ...,  # lattice2d.target_porosity: tune the cell size (Voronoi: the density) until this share of the region is pore, lines lattice2d.line_width wide, as GIPPO Table 1 desi
    threads: int = ...,  # run.threads: worker threads (0 = all cores)
    z: float = ...,  # lattice2d.z: height of the lattice plane
) -> Result: ...

def lattice3d(
    output: PathLike | None = None, *, preview: PathLike | None = None,
    progress: Progress | None = None,
    set: Mapping[str, Any] | None = None,
    box: Sequence[float] = ...,  # lattice3d.box: foam box width, depth, height
    cell: float = ...,  # lattice3d.cell: unit cell side
    cell_type: Literal['cubic', 'bcc', 'fcc', 'octet', 'diamond', 'kelvin', 'rhombic-dodecahedron'] = ...,  # lattice3d.cell_type: unit cell
    count: Sequence[float] = ...,  # lattice3d.count: cells along X, Y, Z
    density: float = ...,  # lattice3d.density: foam seeds per mm³
    follow_symlinks: bool = ...,  # run.follow_symlinks: write an output whose path is a symbolic link to the file it points to (the link kept); without it such an output is refused
    force: bool = ...,  # run.force: run even when the estimate is beyond run.max_memory or run.max_time
    frames: int = ...,  # output.frames: aero: step pictures of the first N trails
    image_size: int = ...,  # output.image_size: preview image size
    kind: Literal['cells', 'foam', 'conformal'] = ...,  # lattice3d.kind: unit cells tessellated, a stochastic Voronoi foam, or cells clipped to a closed mesh (lattice3d.mesh) with an optional stochas
    materials: Literal['none', 'xy-plane', 'component', 'vertical'] = ...,  # lattice3d.materials: per-strut material rule
    max_memory: float = ...,  # run.max_memory: refuse a run whose estimate (made from its settings before it starts) needs more memory than this
    max_time: float = ...,  # run.max_time: refuse a run whose estimated time is longer than this
    mesh: str = ...,  # lattice3d.mesh: foam: inside this closed mesh instead of the box; conformal: the mesh to fill
    radius: float = ...,  # lattice3d.radius: strut radius written to a 3MF beam lattice (-o part.3mf)
    seed: int = ...,  # lattice3d.seed: foam random seed
    skin: float = ...,  # lattice3d.skin: conformal: a stochastic (Voronoi) skin this thick
    skin_density: float = ...,  # lattice3d.skin_density: conformal: skin foam seeds per mm³
    threads: int = ...,  # run.threads: worker threads (0 = all cores)
) -> Result: ...

def plan(
    planner: Literal['gippo', 'euler', 'aero'], lattice: PathLike | Lattice, output: PathLike | None = None, *, machine: Machine | None = None, gcode: PathLike | None = None, report: PathLike | None = None, preview: PathLike | None = None,
    progress: Progress | None = None,
    set: Mapping[str, Any] | None = None,
    arrowhead_inner: float = ...,  # lattice2d.arrowhead_inner: arrowhead: inner chevron angle
    arrowhead_outer: float = ...,  # lattice2d.arrowhead_outer: arrowhead: outer chevron angle
    binary_gcode: bool = ...,  # gcode.binary: write PrusaSlicer's binary G-code (.bgcode: metadata, PNG thumbnails and Heatshrink-compressed G-code blocks with CRC32, as Prusa's firmware reads them) 
    box: Sequence[float] = ...,  # lattice3d.box: foam box width, depth, height
    cell: float = ...,  # lattice2d.cell: cell size: hexagon side, rhombus side, edge or period (see lattice2d --help)
    cell_height: float = ...,  # lattice2d.cell_height: arrowhead and re-entrant honeycomb: the unit cell's vertical length (the cell size is the horizontal one, GIPPO Table 1); sets the arrowhead's i
    cell_type: Literal['cubic', 'bcc', 'fcc', 'octet', 'diamond', 'kelvin', 'rhombic-dodecahedron'] = ...,  # lattice3d.cell_type: unit cell
    center: bool = ...,  # placement.center: move the part's XY centre to the bed centre (false: design coordinates are bed coordinates)
    collisions: bool = ...,  # aero.collisions: plan around the nozzle (false: trails = Euler lower bound)
    cone: float = ...,  # nozzle.cone: struts within this angle of vertical print bottom-up
    contour: bool = ...,  # lattice2d.contour: add the region outline as struts
    count: Sequence[float] = ...,  # lattice3d.count: cells along X, Y, Z
    density: float = ...,  # lattice2d.density: Voronoi seeds per mm²
    diameter: float = ...,  # lattice2d.diameter: circle diameter
    exact_struts: int = ...,  # aero.exact_struts: solve obstruction cycles exactly (integer program) in parts up to this many struts; 0 = local search only
    fewest_collisions: bool = ...,  # aero.fewest_collisions: break obstruction cycles where it costs the fewest collisions (proven minimal where the exact solver finishes); false = the greedy order
    follow_symlinks: bool = ...,  # run.follow_symlinks: write an output whose path is a symbolic link to the file it points to (the link kept); without it such an output is refused
    force: bool = ...,  # run.force: run even when the estimate is beyond run.max_memory or run.max_time
    frames: int = ...,  # output.frames: aero: step pictures of the first N trails
    handle_length: float = ...,  # lattice2d.handle_length: handle length along x
    handle_width: float = ...,  # lattice2d.handle_width: handle width along y
    handles: bool = ...,  # lattice2d.handles: tensile-test handles at both x ends
    image_size: int = ...,  # output.image_size: preview image size
    iterations: int = ...,  # gippo.iterations: solutions generated, best kept (paper: 500)
    keep_graph: bool = ...,  # lattice.keep_graph: the lattice exactly as given: no node merging, no T-junction splitting
    kind: Literal['cells', 'foam', 'conformal'] = ...,  # lattice3d.kind: unit cells tessellated, a stochastic Voronoi foam, or cells clipped to a closed mesh (lattice3d.mesh) with an optional stochas
    layer_height: float = ...,  # extrusion.layer_height: layer thickness LT when a path has none (Eq. 4)
    layer_rotation: float = ...,  # layers.rotation: pattern rotation added per layer
    layers: int = ...,  # layers.count: layers of the 2D pattern (0 with layers.solid: from its height)
    line_width: float = ...,  # lattice2d.line_width: printed line width for the reported pore area
    long_nodes: int = ...,  # plan.long_path_nodes: LTS/OE: a path is long with this many nodes
    lookahead: float = ...,  # gradient.lookahead: issue each mixture change this much printed path before the region (dead volume, FGM paper A.1: L = V_melt / (h(w-h) + pi h^2/4))
    materials: Literal['none', 'xy-plane', 'component', 'vertical'] = ...,  # lattice3d.materials: per-strut material rule
    max_memory: float = ...,  # run.max_memory: refuse a run whose estimate (made from its settings before it starts) needs more memory than this
    max_time: float = ...,  # run.max_time: refuse a run whose estimated time is longer than this
    merge_ends: bool = ...,  # plan.merge_ends: join paths that end at the same node into one (fewer paths and starts; GIPPO keeps its paths as grown otherwise)
    merge_tolerance: float = ...,  # lattice.merge_tolerance: merge nodes closer than this
    mesh: str = ...,  # lattice3d.mesh: foam: inside this closed mesh instead of the box; conformal: the mesh to fill
    method: Literal['dynamic', 'groups', 'periodic'] = ...,  # aero.method: dynamic (refresh after every trail), groups (the paper's) or periodic (the paper's semi-manual baseline: a hand-made cell pa
    mode: Literal['max', 'min'] = ...,  # gippo.mode: take the longest (max) or shortest (min) edge
    node_clearance: float = ...,  # nozzle.node_clearance: no collision within this of a node the two struts share
    nozzle_radius: float = ...,  # nozzle.radius: nozzle radius R (vertical cylinder)
    onto: Literal['', 'sphere-cap', 'mesh', 'function'] = ...,  # onto.kind: lay the planned layers on a surface (empty: flat)
    order: Literal['longest-first', 'travel'] = ...,  # plan.order: path order: longest-first (paper) or travel (nearest neighbour + 2-opt)
    overlap: float = ...,  # nozzle.overlap: the writer's node overlap: struts planned as if this much longer
    pattern: Literal['honeycomb', 'voronoi', 'penrose', 'snub-square', 'arrowhead', 'reentrant-honeycomb', 'square', 'triangle', 'lines'] = ...,  # lattice2d.pattern: atlas pattern
    periodic_cell: Literal['octet', 'bcc', 'cubic'] = ...,  # aero.cell_type: periodic: the lattice's unit cell (its hand-made path is repeated)
    periodic_size: float = ...,  # aero.cell: periodic: the lattice's cell side (a cell corner at its lowest corner)
    preview_layers: int = ...,  # output.preview_layers: PNG previews spread over the layers
    print_path: int = ...,  # aero.print_path: periodic bcc: Print Path 1 (nodes side by side) or 2 (crossing traces), the paper's Fig. 3b
    radius: float = ...,  # lattice3d.radius: strut radius written to a 3MF beam lattice (-o part.3mf)
    reentrant_angle: float = ...,  # lattice2d.reentrant_angle: re-entrant honeycomb: strut angle below horizontal
    region: Literal['rectangle', 'circle'] = ...,  # lattice2d.region: crop region
    region_center: Sequence[float] = ...,  # lattice2d.center: region centre x, y
    ring_spacing: float = ...,  # lattice2d.ring_spacing: distance between clamping rings (two or more)
    rings: int = ...,  # lattice2d.rings: clamping rings: concentric outlines at the region's rim, the pattern inside the innermost (GIPPO's Ø48 ball-burst discs); 0 = none
    rotation: float = ...,  # lattice2d.rotation: pattern rotation about the region centre
    seed: int = ...,  # plan.seed: random seed (gippo iterations, aero shuffled runs)
    seeds: int = ...,  # gippo.seeds: robustness: also run seeds plan.seed .. +N-1 and report the best score's spread (paper Fig. 2 v-vi); 0 = off
    size: Sequence[float] = ...,  # lattice2d.size: rectangle width, height
    skin: float = ...,  # lattice3d.skin: conformal: a stochastic (Voronoi) skin this thick
    skin_density: float = ...,  # lattice3d.skin_density: conformal: skin foam seeds per mm³
    solid: str = ...,  # layers.solid: closed mesh each layer's pattern is cropped to
    speed: float = ...,  # speed.print: printing speed
    strand: float = ...,  # lattice2d.strand: strand distance of square, triangle and lines
    target_porosity: float = ...,  # lattice2d.target_porosity: tune the cell size (Voronoi: the density) until this share of the region is pore, lines lattice2d.line_width wide, as GIPPO Table 1 desi
    threads: int = ...,  # run.threads: worker threads (0 = all cores)
    tip_clearance: float = ...,  # nozzle.tip_clearance: material less than this above the tip is not hit
    tries: int = ...,  # aero.tries: dynamic: planner runs (strategies, then shuffled orders; best kept)
    worst: bool = ...,  # gippo.worst: also write the lowest-score solution beside the best (NAME.worst.json, worst_layer_*.png previews), as the paper compares them
    z: float = ...,  # lattice2d.z: height of the lattice plane
) -> Result: ...

def gcode(
    toolpath: PathLike | Toolpath, output: PathLike | None = None, *, machine: Machine,
    progress: Progress | None = None,
    set: Mapping[str, Any] | None = None,
    binary_gcode: bool = ...,  # gcode.binary: write PrusaSlicer's binary G-code (.bgcode: metadata, PNG thumbnails and Heatshrink-compressed G-code blocks with CRC32, as Prusa's firmware reads them) 
    center: bool = ...,  # placement.center: move the part's XY centre to the bed centre (false: design coordinates are bed coordinates)
    follow_symlinks: bool = ...,  # run.follow_symlinks: write an output whose path is a symbolic link to the file it points to (the link kept); without it such an output is refused
    force: bool = ...,  # run.force: run even when the estimate is beyond run.max_memory or run.max_time
    layer_height: float = ...,  # extrusion.layer_height: layer thickness LT when a path has none (Eq. 4)
    lookahead: float = ...,  # gradient.lookahead: issue each mixture change this much printed path before the region (dead volume, FGM paper A.1: L = V_melt / (h(w-h) + pi h^2/4))
    max_memory: float = ...,  # run.max_memory: refuse a run whose estimate (made from its settings before it starts) needs more memory than this
    max_time: float = ...,  # run.max_time: refuse a run whose estimated time is longer than this
    speed: float = ...,  # speed.print: printing speed
    threads: int = ...,  # run.threads: worker threads (0 = all cores)
) -> Result: ...

def slice(
    design: PathLike | Field, output: PathLike | None = None, *, machine: Machine, report: PathLike | None = None, toolpath: PathLike | None = None, preview: PathLike | None = None,
    progress: Progress | None = None,
    set: Mapping[str, Any] | None = None,
    bead_width: float = ...,  # slice.bead_width: bead width (wall and fill spacing)
    binary_gcode: bool = ...,  # gcode.binary: write PrusaSlicer's binary G-code (.bgcode: metadata, PNG thumbnails and Heatshrink-compressed G-code blocks with CRC32, as Prusa's firmware reads them) 
    bottom: int = ...,  # slice.bottom: solid bottom layers
    center: bool = ...,  # placement.center: move the part's XY centre to the bed centre (false: design coordinates are bed coordinates)
    colors: int = ...,  # fgm.colors: palette size (two materials: N bands; three: d² triangles, e.g. 9)
    comb: bool = ...,  # slice.comb: keep travel inside the part (crossing no outer wall) where a route inside is at most slice.comb_detour times the straight distance; such travel does not retract (r
    comb_detour: float = ...,  # slice.comb_detour: longest route inside the part, as a multiple of the straight distance (plus one bead); a longer one goes straight and retracts
    concentric: bool = ...,  # fgm.concentric: Strategy 2: each colour face filled with concentric rings instead of lines (face by face, in either order)
    connect: bool = ...,  # slice.connect: join skin and infill lines along the edge of their region into serpentines (as PrusaSlicer's connected rectilinear infill); --no-connect prints every line as
    connect_max: float = ...,  # slice.connect_max: longest connector between two fill lines along their region's edge, in line spacings (a longer gap starts a new path)
    fan_step: float = ...,  # process.fan_step: quantum of a fan field
    fgm_perimeters: int = ...,  # fgm.perimeters: Strategy 2, rectilinear: rings around each island's outline (path order) or each colour face (face order) before its lines (the FGM paper's palette pl
    fixed_angle: bool = ...,  # fgm.fixed_angle: Strategy 2: lines at slice.infill_angle instead of along the iso-lines
    flow_step: float = ...,  # process.flow_step: quantum of a flow (extrusion multiplier) field
    follow_symlinks: bool = ...,  # run.follow_symlinks: write an output whose path is a symbolic link to the file it points to (the link kept); without it such an output is refused
    force: bool = ...,  # run.force: run even when the estimate is beyond run.max_memory or run.max_time
    frames: int = ...,  # output.frames: aero: step pictures of the first N trails
    image_size: int = ...,  # output.image_size: preview image size
    infill: float = ...,  # slice.infill: sparse infill density (fraction of solid)
    infill_angle: float = ...,  # slice.infill_angle: infill angle, +90 every other layer
    infill_lattice: Literal['honeycomb', 'voronoi', 'penrose', 'snub-square', 'arrowhead', 'reentrant-honeycomb', 'square', 'triangle', 'lines'] = ...,  # slice.infill_lattice: slice.infill_pattern = 
    infill_pattern: Literal['rectilinear', 'grid', 'triangles', 'honeycomb', 'gyroid', 'concentric', 'lattice'] = ...,  # slice.infill_pattern: sparse infill: rectilinear (lines, turned 90° every laye
    infill_seed: int = ...,  # slice.infill_seed: lattice infill: the Voronoi seed
    layer_height: float = ...,  # extrusion.layer_height: layer thickness LT when a path has none (Eq. 4)
    lookahead: float = ...,  # gradient.lookahead: issue each mixture change this much printed path before the region (dead volume, FGM paper A.1: L = V_melt / (h(w-h) + pi h^2/4))
    material_resolution: float = ...,  # fgm.material_resolution: XY grid of the material iso-contours
    max_memory: float = ...,  # run.max_memory: refuse a run whose estimate (made from its settings before it starts) needs more memory than this
    max_time: float = ...,  # run.max_time: refuse a run whose estimated time is longer than this
    mesh_voxel: float = ...,  # slice.mesh_voxel: voxel of mesh distance fields (field route)
    min_segment: float = ...,  # fgm.min_segment: pieces (Strategy 1) and paths (Strategy 2) shorter than this are joined to a touching piece of another colour where the design stays within α/2 of its
    order: Literal['paths', 'faces'] = ...,  # fgm.order: graded print order: paths (Strategy 1: the planar order kept, each path cut at the colour faces into one bead whose mixture changes where it c
    preview_layers: int = ...,  # output.preview_layers: PNG previews spread over the layers
    process_min_length: float = ...,  # process.min_length: pieces of a path shorter than this are merged into a neighbour (their deviation from the field is reported, a warning beyond half a step)
    process_sample: float = ...,  # process.sample: spacing of the field samples along each path (changes between samples are found by bisection)
    repair: bool = ...,  # slice.repair: repair meshes that are not closed and manifold (stitch seams, drop degenerate and duplicate faces, orient, fill small holes, split non-manifold edges); --no-re
    resolution: float = ...,  # slice.resolution: XY grid step of field contours
    route: Literal['auto', 'field', 'mesh'] = ...,  # slice.route: auto (.vcad: field, meshes: mesh), field (contours of the implicit field) or mesh (plane cuts)
    seam: Literal['aligned', 'nearest', 'rear', 'random'] = ...,  # slice.seam: where each wall loop starts: aligned (a sharp corner, else the rear-most point: the same place on every layer), nearest 
    seam_seed: int = ...,  # slice.seam_seed: random seams: the seed
    speed: float = ...,  # speed.print: printing speed
    speed_step: float = ...,  # process.speed_step: quantum of a speed field (as above)
    strategy: int = ...,  # slice.strategy: graded designs (FGM paper): 1 walls/infill cut by colour faces + purge, 2 colour faces filled densely, none (0) one material on purpose; a graded design wit
    temperature_step: float = ...,  # process.temperature_step: quantum of a temperature field: written rounded to it (within half a step), a path split where the rounded value changes
    threads: int = ...,  # run.threads: worker threads (0 = all cores)
    top: int = ...,  # slice.top: solid top layers
    walls: int = ...,  # slice.walls: number of walls
    zipper: float = ...,  # fgm.zipper: Strategy 1: overlap band β (fraction of the gradient) where colours alternate
) -> Result: ...

def pbf(
    output: PathLike | None = None, *, envelope: PathLike | Field | None = None, machine: Machine | None = None, report: PathLike | None = None, toolpath: PathLike | None = None, preview: PathLike | None = None,
    progress: Progress | None = None,
    set: Mapping[str, Any] | None = None,
    beam_comp: float = ...,  # scan.beam_compensation: beam compensation: hatch ends pulled in by this
    binary: bool = ...,  # pbf.binary: binary CLI geometry (the header stays ASCII, with CLI+ blocks)
    c: str = ...,  # pbf.c: sheet parameter c (Φ = φ² − c²): a number or an expression of x, y, z, rho, r
    cell: float = ...,  # pbf.cell: TPMS cell size
    cell_type: Literal['gyroid', 'schwarz_p', 'schwarz_d', 'neovius', 'iwp'] = ...,  # pbf.cell_type: TPMS of the sheet
    contour_distance: float = ...,  # pbf.contour_distance: solid parts: between contours, and from the last one to the hatch
    contours: int = ...,  # pbf.contours: solid parts: contour offsets per layer region, the first at the beam compensation (0: hatch only)
    core_hatch: float = ...,  # pbf.core_hatch_distance: solid parts: hatch distance in the core
    downskin_hatch: float = ...,  # pbf.downskin_hatch_distance: solid parts: hatch distance in down-skin
    downskin_thickness: float = ...,  # pbf.downskin_thickness: solid parts: the part of a layer with no material somewhere in this thickness of layers below it is down-skin (laser.downskin_*)
    envelope: str = ...,  # pbf.envelope: .vcad solid the lattice fills instead of the box
    follow_symlinks: bool = ...,  # run.follow_symlinks: write an output whose path is a symbolic link to the file it points to (the link kept); without it such an output is refused
    force: bool = ...,  # run.force: run even when the estimate is beyond run.max_memory or run.max_time
    frames: int = ...,  # output.frames: aero: step pictures of the first N trails
    grade_axis: Literal['z', 'r'] = ...,  # pbf.grade_axis: grading axis: z (axial) or r (radial)
    grade_center: float = ...,  # pbf.grade_center: sigmoid centre
    grade_to: str = ...,  # pbf.grade_to: TYPE:CELL blended in by a sigmoid (graded cell size)
    grade_width: float = ...,  # pbf.grade_width: sigmoid width
    hatch: float = ...,  # scan.hatch_distance: hatch distance
    hatch_phase: Literal['wall', 'origin', 'random'] = ...,  # pbf.hatch_phase: where hatch lines are fixed each layer: through the design's origin (wall: the Fig. 3 wall's centre, a solid part's orig
    hatch_rotation: float = ...,  # pbf.hatch_rotation: hatch rotation per layer (paper: 67)
    hatch_seed: int = ...,  # pbf.hatch_seed: random hatch phase: seed of the layers' shifts
    hierarchical: str = ...,  # pbf.hierarchical: TYPE:CELL:WEIGHT superposed (hierarchical lattice)
    image_size: int = ...,  # output.image_size: preview image size
    island_overlap: float = ...,  # pbf.island_overlap: island: neighbouring islands overlap
    island_shift: float = ...,  # pbf.island_shift: island: the island grid moves this far along both its axes every layer
    island_size: float = ...,  # pbf.island_size: island: side of the square islands
    laser_overlap: float = ...,  # pbf.laser_overlap: neighbouring lasers' stripes overlap: a vector crossing a boundary by at most half this goes whole to one laser, a longer one is cut there
    laser_split_axis: Literal['x', 'y', 'auto'] = ...,  # pbf.laser_split_axis: the lasers' stripes follow one another along X (laser 1 leftmost), along Y (laser 1 at the front), or per layer along th
    lasers: int = ...,  # laser.lasers: lasers scanning each layer at once; pbf splits every layer among them in stripes along X balanced by scan time (docs/laser.md)
    layer_height: float = ...,  # scan.layer: powder layer thickness
    lhd: float = ...,  # scan.segment_gap: gap LHD between contour scan vectors (the paper tested 0-120 µm; outside is a warning)
    max_memory: float = ...,  # run.max_memory: refuse a run whose estimate (made from its settings before it starts) needs more memory than this
    max_time: float = ...,  # run.max_time: refuse a run whose estimated time is longer than this
    min_inclination: float = ...,  # pbf.min_inclination: shallower walls are hatched
    plate_position: Sequence[float] = ...,  # pbf.plate_position: where the design's origin sits on the build plate (X, Y from the machine origin): the origin hatch phase's grid
    preview_layers: int = ...,  # output.preview_layers: PNG previews spread over the layers
    resolution: float = ...,  # pbf.resolution: sampling step: the STL route's voxel; direct contours on a grid twice as coarse
    route: Literal['direct', 'stl'] = ...,  # pbf.route: direct (slice the field) or stl (marching cubes mesh, for comparison)
    size: Sequence[float] = ...,  # pbf.size: box X, Y, Z centred at the origin
    skin_thickness: float = ...,  # pbf.skin_thickness: solid parts: the core, at least this far inside the part's surface (in XY and in the layers above and below), is hatched with the core parameter
    sl: float = ...,  # scan.segment_length: contour scan vector length SL: straight chords on φ = 0 (the paper tested 5-400 µm; outside is a warning)
    solids: str = ...,  # pbf.solids: .vcad solid parts (bosses), hatched
    split: Literal['width', 'inclination'] = ...,  # pbf.split: thin walls against joints: width <= pbf.thin_multiple × D and steeper than pbf.min_inclination (width), or the paper's c interpolated by
    strategy: Literal['hybrid', 'r67', 'rectilinear', 'meander', 'stripe', 'island'] = ...,  # pbf.strategy: TPMS sheets: hybrid (contours on thin walls, hatch at joints) or r67 (hatch everything); so
    stripe_overlap: float = ...,  # pbf.stripe_overlap: stripe: neighbouring stripes overlap
    stripe_width: float = ...,  # pbf.stripe_width: stripe: width across the hatch lines
    thickness: float = ...,  # pbf.thickness: uniform wall thickness t: c = t·|∇φ|/2 instead of pbf.c
    thin_multiple: float = ...,  # pbf.thin_multiple: thin wall: width <= this × melt pool
    threads: int = ...,  # run.threads: worker threads (0 = all cores)
    upskin_hatch: float = ...,  # pbf.upskin_hatch_distance: solid parts: hatch distance in up-skin
    upskin_thickness: float = ...,  # pbf.upskin_thickness: solid parts: the part of a layer with no material somewhere in this thickness of layers above it is up-skin (laser.upskin_*)
    wall_azimuth: float = ...,  # pbf.wall_azimuth: the wall's direction from X
    wall_inclination: float = ...,  # pbf.wall_inclination: the wall's angle from horizontal
    wall_thickness: float = ...,  # pbf.wall_thickness: a plane thin wall of this thickness instead of a TPMS (PBF paper Fig. 3; box from pbf.size, default 2,2,20)
) -> Result: ...

def nonplanar(
    surface: PathLike | None = None, output: PathLike | None = None, *, machine: Machine, report: PathLike | None = None, toolpath: PathLike | None = None, preview: PathLike | None = None,
    progress: Progress | None = None,
    set: Mapping[str, Any] | None = None,
    amplitude_scale: float = ...,  # surface.amplitude_scale: corrugation amplitude factor
    angle: float = ...,  # surface.angle: corrugation slope
    angles: Sequence[float] = ...,  # nonplanar.angles: path directions cycled over the layers (0,90 = cross-hatch; 0 = parallel)
    bead_width: float = ...,  # nonplanar.bead_width: path width = plane spacing
    binary_gcode: bool = ...,  # gcode.binary: write PrusaSlicer's binary G-code (.bgcode: metadata, PNG thumbnails and Heatshrink-compressed G-code blocks with CRC32, as Prusa's firmware reads them) 
    center: bool = ...,  # placement.center: move the part's XY centre to the bed centre (false: design coordinates are bed coordinates)
    chord_tol: float = ...,  # nonplanar.chord_tolerance: max distance of a path segment from the surface
    depth: float = ...,  # surface.depth: Miura-Ori fold depth
    diameter: float = ...,  # surface.diameter: sphere-cap footprint diameter
    domain: Sequence[float] = ...,  # nonplanar.domain: x0, y0, x1, y1 of the height function
    fillet: float = ...,  # surface.fillet: fillet diameter at peaks and valleys
    flat: float = ...,  # surface.flat: flat clamping end length
    follow_symlinks: bool = ...,  # run.follow_symlinks: write an output whose path is a symbolic link to the file it points to (the link kept); without it such an output is refused
    force: bool = ...,  # run.force: run even when the estimate is beyond run.max_memory or run.max_time
    frames: int = ...,  # output.frames: aero: step pictures of the first N trails
    height: float = ...,  # surface.height: M curve height
    height_fn: str = ...,  # nonplanar.height_fn: surface z = f(x, y) instead of a mesh (muparser)
    image_size: int = ...,  # output.image_size: preview image size
    kind: Literal['corrugation', 'miura', 'm-curve', 'sphere-cap', 'angle-test'] = ...,  # surface.kind: generated test surface (non-planar paper)
    layer_height: float = ...,  # extrusion.layer_height: layer thickness LT when a path has none (Eq. 4)
    layer_tools: str = ...,  # nonplanar.layer_tools: tools per layer: LAYERS:TOOL groups (3:0,3:1,3:0) or a tool list (0,1)
    layers: int = ...,  # nonplanar.layers: number of layers
    length: float = ...,  # surface.length: length along X
    lookahead: float = ...,  # gradient.lookahead: issue each mixture change this much printed path before the region (dead volume, FGM paper A.1: L = V_melt / (h(w-h) + pi h^2/4))
    max_join: float = ...,  # nonplanar.max_join: longest end-to-end connector printed instead of a travel
    max_memory: float = ...,  # run.max_memory: refuse a run whose estimate (made from its settings before it starts) needs more memory than this
    max_time: float = ...,  # run.max_time: refuse a run whose estimated time is longer than this
    offset: Literal['vertical', 'normal'] = ...,  # nonplanar.offset: layers stack vertically (paper) or along the surface normal
    periods: float = ...,  # surface.periods: corrugation periods
    planar_control: bool = ...,  # nonplanar.planar_control: the planar control (non-planar paper, Fig. 3C/E): the solid the layers fill sliced flat, each layer group's band in its tool
    preview_layers: int = ...,  # output.preview_layers: PNG previews spread over the layers
    radius: float = ...,  # surface.radius: sphere-cap radius
    resolution: float = ...,  # surface.resolution: grid spacing of generated meshes
    speed: float = ...,  # speed.print: printing speed
    surface_spacing: bool = ...,  # nonplanar.surface_spacing: lines one width apart along the surface (arc length), not in the slicing planes
    threads: int = ...,  # run.threads: worker threads (0 = all cores)
    width: float = ...,  # surface.width: width along Y
) -> Result: ...

def surface(
    kind: Literal['corrugation', 'miura', 'm-curve', 'sphere-cap', 'angle-test'], output: PathLike | None = None, *, machine: Machine | None = None, preview: PathLike | None = None,
    progress: Progress | None = None,
    set: Mapping[str, Any] | None = None,
    amplitude_scale: float = ...,  # surface.amplitude_scale: corrugation amplitude factor
    angle: float = ...,  # surface.angle: corrugation slope
    binary_gcode: bool = ...,  # gcode.binary: write PrusaSlicer's binary G-code (.bgcode: metadata, PNG thumbnails and Heatshrink-compressed G-code blocks with CRC32, as Prusa's firmware reads them) 
    center: bool = ...,  # placement.center: move the part's XY centre to the bed centre (false: design coordinates are bed coordinates)
    depth: float = ...,  # surface.depth: Miura-Ori fold depth
    diameter: float = ...,  # surface.diameter: sphere-cap footprint diameter
    fillet: float = ...,  # surface.fillet: fillet diameter at peaks and valleys
    flat: float = ...,  # surface.flat: flat clamping end length
    follow_symlinks: bool = ...,  # run.follow_symlinks: write an output whose path is a symbolic link to the file it points to (the link kept); without it such an output is refused
    force: bool = ...,  # run.force: run even when the estimate is beyond run.max_memory or run.max_time
    frames: int = ...,  # output.frames: aero: step pictures of the first N trails
    height: float = ...,  # surface.height: M curve height
    image_size: int = ...,  # output.image_size: preview image size
    layer_height: float = ...,  # extrusion.layer_height: layer thickness LT when a path has none (Eq. 4)
    length: float = ...,  # surface.length: length along X
    lookahead: float = ...,  # gradient.lookahead: issue each mixture change this much printed path before the region (dead volume, FGM paper A.1: L = V_melt / (h(w-h) + pi h^2/4))
    max_memory: float = ...,  # run.max_memory: refuse a run whose estimate (made from its settings before it starts) needs more memory than this
    max_time: float = ...,  # run.max_time: refuse a run whose estimated time is longer than this
    periods: float = ...,  # surface.periods: corrugation periods
    radius: float = ...,  # surface.radius: sphere-cap radius
    resolution: float = ...,  # surface.resolution: grid spacing of generated meshes
    speed: float = ...,  # speed.print: printing speed
    threads: int = ...,  # run.threads: worker threads (0 = all cores)
    width: float = ...,  # surface.width: width along Y
) -> Result: ...

def run_job(job: PathLike | Mapping[str, Mapping[str, Any]], output_dir: PathLike | None = None,
            set: Mapping[str, Any] | None = None, progress: Progress | None = None) -> Result: ...
def rerun(path: PathLike, output: PathLike | None = None) -> list[str]: ...
def settings(route: str | None = None) -> list[dict[str, Any]]: ...
def read_lattice(path: PathLike, merge_tolerance: float = 1e-6) -> Lattice: ...
def read_toolpath(path: PathLike, *, commanded_mixtures: bool = ...) -> Toolpath: ...
def notebook_viewer() -> Any: ...
def parse_vcad(text: str, name: str = ...) -> dict[str, Any]: ...
from .fields import (Field, Mesh, cone, cube, cylinder, difference, fgrade, function, gyroid,
                     intersection, mesh, rectprism, sphere, torus, tpms, union)

def check(
    lattice: PathLike | Lattice, print_file: PathLike | Toolpath, *, machine: Machine | None = None, report: PathLike | None = None, preview: PathLike | None = None,
    set: Mapping[str, Any] | None = None,
    commanded_mixtures: bool = ...,  # read.commanded_mixtures: graded G-code with a mixing look-ahead: read the mixtures as commanded (the file's lines), not as deposited (the look-ahead undone, the 
    cone: float = ...,  # nozzle.cone: struts within this angle of vertical print bottom-up
    follow_symlinks: bool = ...,  # run.follow_symlinks: write an output whose path is a symbolic link to the file it points to (the link kept); without it such an output is refused
    force: bool = ...,  # run.force: run even when the estimate is beyond run.max_memory or run.max_time
    keep_graph: bool = ...,  # lattice.keep_graph: the lattice exactly as given: no node merging, no T-junction splitting
    max_memory: float = ...,  # run.max_memory: refuse a run whose estimate (made from its settings before it starts) needs more memory than this
    max_time: float = ...,  # run.max_time: refuse a run whose estimated time is longer than this
    merge_tolerance: float = ...,  # lattice.merge_tolerance: merge nodes closer than this
    node_clearance: float = ...,  # nozzle.node_clearance: no collision within this of a node the two struts share
    nozzle_radius: float = ...,  # nozzle.radius: nozzle radius R (vertical cylinder)
    overlap: float = ...,  # nozzle.overlap: the writer's node overlap: struts planned as if this much longer
    snap: float = ...,  # check.snap: segment ends within this of a node are at it (at this default, plus the machine profile's node overlap)
    tip_clearance: float = ...,  # nozzle.tip_clearance: material less than this above the tip is not hit
) -> dict[str, Any]: ...

def analyze(
    gcode: PathLike | Toolpath, design: PathLike | Lattice | None = None, *, machine: Machine | None = None, report: PathLike | None = None, preview: PathLike | None = None,
    set: Mapping[str, Any] | None = None,
    acceleration: float = ...,  # analyze.acceleration: for the print-time estimate when the file sets none (its M204 or our header's speed.acceleration win; 0 = feed rates only)
    align: bool = ...,  # analyze.align: move the print's XY centre onto the design's (for parts placed on the bed; done anyway, with a note, when the print lies mostly outside the design)
    bead_width: float = ...,  # analyze.bead_width: bead width: deposits within width/2 cover a strut
    commanded_mixtures: bool = ...,  # read.commanded_mixtures: graded G-code with a mixing look-ahead: read the mixtures as commanded (the file's lines), not as deposited (the look-ahead undone, the 
    filament_diameter: float = ...,  # analyze.filament_diameter: build plates: filament diameter for each part's volume
    follow_symlinks: bool = ...,  # run.follow_symlinks: write an output whose path is a symbolic link to the file it points to (the link kept); without it such an output is refused
    layer_height: float = ...,  # analyze.layer_height: nozzle z = design z + this
    layers: bool = ...,  # analyze.layers: also print a line per layer: extrusion starts (with a design, beside the fewest paths its struts allow), retractions, travel moves and length
    strict: bool = ...,  # read.strict: stop at the first unreadable line (default: warn and skip)
    valve_off: str = ...,  # read.valve_off: pneumatic files: the command that closes the valve
    valve_on: str = ...,  # read.valve_on: pneumatic files: the command that opens the valve (empty: the machine profile's, else the file's header)
) -> dict[str, Any]: ...

def compare(
    design: PathLike, *gcode: PathLike, report: PathLike | None = None, preview: PathLike | None = None,
    set: Mapping[str, Any] | None = None,
    acceleration: float = ...,  # analyze.acceleration: for the print-time estimate when the file sets none (its M204 or our header's speed.acceleration win; 0 = feed rates only)
    align: bool = ...,  # analyze.align: move the print's XY centre onto the design's (for parts placed on the bed; done anyway, with a note, when the print lies mostly outside the design)
    bead_width: float = ...,  # analyze.bead_width: bead width: deposits within width/2 cover a strut
    commanded_mixtures: bool = ...,  # read.commanded_mixtures: graded G-code with a mixing look-ahead: read the mixtures as commanded (the file's lines), not as deposited (the look-ahead undone, the 
    follow_symlinks: bool = ...,  # run.follow_symlinks: write an output whose path is a symbolic link to the file it points to (the link kept); without it such an output is refused
    layer_height: float = ...,  # analyze.layer_height: nozzle z = design z + this
    layers: bool = ...,  # analyze.layers: also print a line per layer: extrusion starts (with a design, beside the fewest paths its struts allow), retractions, travel moves and length
    strict: bool = ...,  # read.strict: stop at the first unreadable line (default: warn and skip)
    valve_off: str = ...,  # read.valve_off: pneumatic files: the command that closes the valve
    valve_on: str = ...,  # read.valve_on: pneumatic files: the command that opens the valve (empty: the machine profile's, else the file's header)
) -> list[dict[str, Any]]: ...

def view(
    *files: PathLike, output: PathLike | None = None, design: PathLike | None = None, machine: Machine | None = None,
    set: Mapping[str, Any] | None = None,
    cone: float = ...,  # nozzle.cone: struts within this angle of vertical print bottom-up
    follow_symlinks: bool = ...,  # run.follow_symlinks: write an output whose path is a symbolic link to the file it points to (the link kept); without it such an output is refused
    keep_graph: bool = ...,  # lattice.keep_graph: the lattice exactly as given: no node merging, no T-junction splitting
    merge_tolerance: float = ...,  # lattice.merge_tolerance: merge nodes closer than this
    node_clearance: float = ...,  # nozzle.node_clearance: no collision within this of a node the two struts share
    nozzle_radius: float = ...,  # nozzle.radius: nozzle radius R (vertical cylinder)
    overlap: float = ...,  # nozzle.overlap: the writer's node overlap: struts planned as if this much longer
    snap: float = ...,  # check.snap: segment ends within this of a node are at it (at this default, plus the machine profile's node overlap)
    tip_clearance: float = ...,  # nozzle.tip_clearance: material less than this above the tip is not hit
    title: str = ...,  # view.title: page title (empty: the file names)
    valve_off: str = ...,  # read.valve_off: pneumatic files: the command that closes the valve
    valve_on: str = ...,  # read.valve_on: pneumatic files: the command that opens the valve (empty: the machine profile's, else the file's header)
) -> str: ...

def render(
    toolpath: PathLike, output: PathLike, *, machine: Machine | None = None,
    progress: Progress | None = None,
    set: Mapping[str, Any] | None = None,
    bead_width: float = ...,  # render.bead_width: line width
    colour: Literal['auto', 'feature', 'order', 'mixture', 'commanded', 'tool', 'set'] = ...,  # render.colour: what colour means: feature, order, mixture (as deposited), commanded (the mixture as com
    follow_symlinks: bool = ...,  # run.follow_symlinks: write an output whose path is a symbolic link to the file it points to (the link kept); without it such an output is refused
    force: bool = ...,  # run.force: run even when the estimate is beyond run.max_memory or run.max_time
    image_size: int = ...,  # render.image_size: image size in pixels
    layer: int = ...,  # render.layer: layer index (0-based): one PNG, written to -o
    max_memory: float = ...,  # run.max_memory: refuse a run whose estimate (made from its settings before it starts) needs more memory than this
    max_time: float = ...,  # run.max_time: refuse a run whose estimated time is longer than this
    travel: bool = ...,  # render.travel: draw travel moves (dashed grey)
    valve_off: str = ...,  # read.valve_off: pneumatic files: the command that closes the valve
    valve_on: str = ...,  # read.valve_on: pneumatic files: the command that opens the valve (empty: the machine profile's, else the file's header)
) -> list[str]: ...
