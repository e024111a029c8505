"""Settings as PropertyGroups: ``Scene.vtskin`` (tool settings) and ``Object.vtskin`` (per skin).

Stored in the .blend, so a saved file reopens with its skins, settings and results.
Lengths are shown in millimetres in the UI and stored in metres (Blender's unit
system with ``subtype='DISTANCE'``), so values reach ``vtcore`` in SI unchanged.
"""

from __future__ import annotations

import bpy
from bpy.props import (BoolProperty, EnumProperty, FloatProperty, IntProperty, PointerProperty,
                       StringProperty)

COLOR_BY = [
    ("response", "Response", "Sensor response (counts)"),
    ("response_compensated", "Compensated", "Recorded response above each taxel's baseline (counts)"),
    ("pressure", "Pressure", "Pressure at the taxels (Pa)"),
    ("edge", "Edge", "Taxels on an edge of the contact"),
    ("tactile_color", "Tactile colour", "Colour propagated onto a point cloud"),
    ("strain", "Strain", "Stretch of each taxel's module edges on the surface (%), from the last layout edit"),
    ("overlap", "Overlap", "Taxels closer than 0.75 pitch to another module's"),
    ("module_id", "Module", "The module each taxel belongs to"),
]


def _color_by_changed(settings, context):
    from . import display

    ob = settings.id_data
    if isinstance(ob, bpy.types.Object):
        display.set_color_by(ob, settings.color_by)


class VTSKIN_PG_object(bpy.types.PropertyGroup):
    """Per-object data: what this object is to the add-on and its baked cache."""

    role: EnumProperty(name="Role", items=[
        ("NONE", "None", "Not part of a skin"),
        ("TAXELS", "Taxels", "One vertex per taxel, skin mesh as faces"),
        ("CLOUD", "Point cloud", "Augmented point cloud"),
    ], default="NONE")
    source: StringProperty(name="Source", description="Where the taxels came from (scene file, layout file, placement)")
    end_effector: PointerProperty(name="End-effector", type=bpy.types.Object,
                                  description="The mesh the skin lies on")
    # A robot link object (Import Robot): its mesh data is the link's geometry in link coordinates
    link: StringProperty(name="Link", default="", description="The robot link this object is (empty: not a link)")
    robot_file: StringProperty(name="Robot file", default="", subtype="FILE_PATH",
                               description="The URDF or MJCF file the link was imported from")
    geometry: StringProperty(name="Geometry", default="", description="visual or collision: what the mesh shows")
    color_by: EnumProperty(name="Colour by", items=COLOR_BY, default="response",
                           update=_color_by_changed)
    cache: PointerProperty(name="Bake cache", type=bpy.types.Mesh,
                           description="Mesh datablock holding one attribute per baked frame")
    bake_start: IntProperty(name="Baked from", default=0)
    bake_end: IntProperty(name="Baked to", default=-1)
    module_type: StringProperty(name="Module type", default="cyskin10")
    # Placement report of the last layout edit (shown in the Skin layout panel).
    strain_max: FloatProperty(name="Max strain", default=0.0, subtype="PERCENTAGE",
                              description="Largest |stretch| of a module edge (percent)")
    strain_mean: FloatProperty(name="Mean strain", default=0.0, subtype="PERCENTAGE")
    overlaps: IntProperty(name="Overlaps", default=0, description="Pairs of modules that overlap")
    coverage: FloatProperty(name="Coverage", default=-1.0, subtype="PERCENTAGE",
                            description="Share of the region under module outlines (-1: unknown)")
    report: StringProperty(name="Placement report", default="",
                           description="The last layout edit's placement report, one finding a line")
    warnings: StringProperty(name="Warnings", default="",
                             description="What the last layout edit warned about, one warning a line")
    show_ids: BoolProperty(name="Show taxel ids", default=False,
                           description="Draw each taxel's id next to it in the viewport")
    force: FloatProperty(name="Force", default=0.0, unit="NONE", description="Force of the last contact (N)")
    edge_threshold: FloatProperty(name="Edge threshold", default=0.0,
                                  description="Edge response threshold used (counts^2/m)")
    # The recording loaded into the cache (shown in the Replay panel).
    replay_source: StringProperty(name="Recording", default="", description="File of the loaded recording")
    replay_rows: IntProperty(name="Recorded rows", default=0)
    recording_hz: FloatProperty(name="Recording rate (Hz)", default=0.0)
    lost_rows: IntProperty(name="Lost rows", default=0,
                           description="Recorded rows with a lost sample of a recorded taxel")
    lost_samples: IntProperty(name="Lost samples", default=0)
    lost_frames: IntProperty(name="Lost frames", default=0,
                             description="Frames that show a held (last good) value for a lost sample")
    exposure_legend: StringProperty(name="Exposure legend", default="",
                                    description="What the link's face colours mean (Import Robot): its exposed "
                                                "surface, faces another link covers, faces no fingertip reaches")
    map_legend: StringProperty(name="Map legend", default="",
                               description="The design map's legend and summary, one line each (Evaluate Skin)")
    replay_report: StringProperty(name="Replay report", default="",
                                  description="The mismatch report and the decoder's summary, one finding a line")


def _modules():
    from vtcore.layout import MODULES

    # every module type of vtcore's registry, with the registry's own description
    return [(k, f"{k} ({len(m)} taxels)", m.doc or k) for k, m in sorted(MODULES.items())]


def _materials():
    from vtcore.contact import MATERIALS

    return [(k, k.replace("_", " ").title(), f"E = {v['young_modulus'] / 1e3:.0f} kPa")
            for k, v in MATERIALS.items()]


def _formats():
    from vtcore.layout import FORMATS

    return [(f, f, f"vtcore layout format {f}") for f in FORMATS]


def _codecs():
    from vtcore.can.timeline import KINDS

    words = {"cyskin16": "CySkin CAN log (cyskin16)", "icub": "iCub CAN log", "cyskin-txt": "CySkin text recording"}
    return [(k, words.get(k, k), f"vtcore recording kind {k}") for k in KINDS]


def _read_formats():
    from vtcore.layout.io import READ_FORMATS

    return [("AUTO", "Auto", "From the file's name and content")] + [(f, f, f"vtcore layout format {f}")
                                                                     for f in READ_FORMATS]


_CODECS = _codecs()
_READ_FORMATS = _read_formats()
_MATERIALS = _materials()
_FORMATS = _formats()


def _live_touch_changed(settings, context):
    from . import live

    live.toggle(context.scene, settings.live_touch)


def _map_show_changed(settings, context):
    from . import ops_evaluate

    ops_evaluate.show_map(context.scene, settings.map_show)


def _mesh_poll(self, ob):
    return ob.type == "MESH"


class VTSKIN_PG_scene(bpy.types.PropertyGroup):
    """Tool settings of the sidebar panels."""

    # Skin layout
    patch: EnumProperty(name="Patch", items=[("hexagon", "Hexagon", "Six modules round a centre"),
                                              ("triangle", "Triangle", "One module"),
                                              ("strip", "Strip", "A row of modules")], default="hexagon")
    strip_modules: IntProperty(name="Modules", default=4, min=1, max=64)
    module: EnumProperty(name="Module", items=_modules(), default="cyskin10")
    mirror: BoolProperty(name="Mirror", default=False,
                         description="Mirror-image modules (skinGui's mirror column: x negated in the module frame)")
    place_at: EnumProperty(name="At", items=[("CURSOR", "3D cursor", "Centre the patch at the 3D cursor"),
                                             ("SELECTED", "Selected faces", "Centre at the selected faces")],
                           default="CURSOR")
    rotation: FloatProperty(name="Orientation", default=0.0, subtype="ANGLE",
                            description="Turn of the patch about the surface normal")
    offset: FloatProperty(name="Offset", default=0.0, subtype="DISTANCE", unit="LENGTH",
                          description="Height of the taxels above the surface (e.g. PCB thickness)")
    method: EnumProperty(name="Method", items=[("logmap", "Log map", "Geodesic (discrete exponential map)"),
                                               ("project", "Project", "Project the flat patch")],
                         default="logmap")
    fill_region: EnumProperty(name="Fill", default="SELECTED", items=[
        ("SELECTED", "Selected faces", "The faces selected on the end-effector (in Edit Mode or kept from it)"),
        ("RADIUS", "Radius round cursor", "Every face within a geodesic radius of the 3D cursor"),
        ("FACING", "Facing a direction", "The faces whose normal is within an angle of a direction "
                                         "(of the selection, if any faces are selected)")])
    fill_radius: FloatProperty(name="Radius", default=0.05, min=1e-4, subtype="DISTANCE", unit="LENGTH",
                               description="Geodesic radius of the fill round the 3D cursor")
    facing: bpy.props.FloatVectorProperty(name="Facing", default=(0.0, 0.0, 1.0), subtype="DIRECTION", size=3,
                                          description="Fill the faces whose normal points this way "
                                                      "(in the end-effector's frame)")
    within: FloatProperty(name="Within", default=0.7853981633974483, min=1e-3, max=3.141592653589793,
                          subtype="ANGLE", description="Cone round the facing direction")
    fill_anywhere: BoolProperty(name="Anywhere on the link", default=False,
                                description="Fill on a robot's link object (Import Robot): fill the whole region "
                                            "as on any mesh, also where another link covers the surface or no "
                                            "fingertip reaches (off: the link's exposed surface only, as vtcore "
                                            "layout fill ROBOT --link)")
    islands: EnumProperty(name="Islands", default="each", items=[
        ("each", "Each its own", "Every connected part of the region gets its own lattice (most modules)"),
        ("one", "One lattice", "Parts within two pitches of each other share one lattice (rows line up)")])
    crease_angle: FloatProperty(name="Crease angle", default=0.6981317007977318, min=0.01, max=3.141592653589793,
                                subtype="ANGLE",
                                description="No module crosses an edge where the faces turn more than this "
                                            "(40 degrees: a design crease); raise it when a coarse mesh's "
                                            "facets are not creases of the part")
    max_strain: FloatProperty(name="Strain limit", default=0.0, min=0.0, max=100.0, subtype="PERCENTAGE",
                              description="Largest stretch of a module edge (percent). 0: the defaults, 5 % "
                                          "(Fill leaves out modules straining more) and 10 % (a patch straining "
                                          "more is refused)")
    keep_refused: BoolProperty(name="Keep anyway", default=False,
                               description="Keep a placement that has taxels off the surface, is over-strained or lies far "
                                    "from the cursor (refused otherwise); it is kept with warnings")
    solve_faces: IntProperty(name="Solve faces", default=20000, min=0,
                             description="Solve the log map on a copy simplified to about this many faces "
                                         "(0: the full mesh); fewer is faster and less accurate")
    # Soft layer
    thickness: FloatProperty(name="Thickness", default=0.003, min=0.0, subtype="DISTANCE", unit="LENGTH",
                             precision=4)
    material: EnumProperty(name="Material", items=_MATERIALS)
    # Contact
    indenter: PointerProperty(name="Indenter", type=bpy.types.Object, poll=_mesh_poll)
    use_force: BoolProperty(name="Target force", default=True,
                            description="Press to the target force (off: use the indenter's pose as it is)")
    force: FloatProperty(name="Force (N)", default=2.0, min=0.0, description="Target normal force, newtons")
    geometry: EnumProperty(name="Solve on", default="plane", items=[
        ("plane", "Plane", "The plane normal to the press: fast, exact for flat patches"),
        ("unrolled", "Unrolled skin", "The patch's own flat coordinates, the layer compressed along its normals: "
                                      "curved patches (one laid patch; merged patches have no common unrolling)")])
    # the sensor: the shipped CySkin profile, as on the command line, unless a gain is typed as an override
    gain_override: BoolProperty(name="Override gain", default=False,
                                description="Simulate, evaluate and touch live with the gain below instead of the "
                                            "CySkin sensor profile's fitted response (the command line's default)")
    counts_per_pa: FloatProperty(name="Gain (counts/Pa)", default=1.53, min=1e-6,
                                 description="Sensor gain used when Override gain is on, counts per pascal")

    def sensor_gain(self):
        """counts/Pa for vtcore: the typed gain when overridden, else None (the sensor profile's)."""
        return self.counts_per_pa if self.gain_override else None
    frame_start: IntProperty(name="Start", default=1)
    frame_end: IntProperty(name="End", default=24)
    # Filters
    edge_fraction: FloatProperty(name="Edge threshold", default=0.3, min=0.0, max=1.0, subtype="FACTOR",
                                 description="Threshold as a fraction of the frame's largest edge response")
    # Augmented point cloud
    cloud: PointerProperty(name="Point cloud", type=bpy.types.Object, poll=_mesh_poll)
    probe_source: EnumProperty(name="Probes", items=[
        ("SELECTED", "Selected vertices", "Selected cloud vertices, values from the probe attribute"),
        ("FILE", "File", "A recorded probe file (CSV/NPZ)")], default="SELECTED")
    probe_file: StringProperty(name="Probe file", subtype="FILE_PATH")
    probe_attribute: StringProperty(name="Probe values", default="compliance",
                                    description="Float attribute of the cloud holding the probe values")
    propagation: EnumProperty(name="Method", items=[("cluster", "Cluster", "Nearest probe (Eq. 2)"),
                                                    ("smooth", "Smooth", "Softmax of distance (Eqs. 3-4)")],
                              default="smooth")
    beta: FloatProperty(name="Beta (1/m)", default=-300.0, max=0.0)
    # Export
    export_path: StringProperty(name="File", subtype="FILE_PATH")
    export_format: EnumProperty(name="Format", items=_FORMATS)
    export_frame: PointerProperty(name="In frame of", type=bpy.types.Object,
                                  description="Write positions in this object's frame (empty: the skin's own)")

    # Robot (Import Robot, Import Layout, Export Skinned Robot)
    robot_file: StringProperty(name="Robot", subtype="FILE_PATH", description="A URDF or MJCF robot")
    robot_geometry: EnumProperty(name="Geometry", items=[
        ("visual", "Visual", "The links' visual meshes (what the robot looks like)"),
        ("collision", "Collision", "The links' collision meshes (what a simulator touches)")], default="visual")
    robot_joints: StringProperty(name="Joints", default="",
                                 description="Joint values to import at, e.g. elbow=0.5, wrist=-1 (empty: zero pose)")
    robot_packages: StringProperty(name="Packages", default="",
                                   description="Where package:// packages are: NAME=FOLDER; NAME2=FOLDER2")
    layout_file: StringProperty(name="Layout", subtype="FILE_PATH",
                                description="A calibrated layout (json, iCub positions, CySkin JSON, csv, ply)")
    layout_format: EnumProperty(name="Format", items=_READ_FORMATS, default="AUTO")
    layout_units: EnumProperty(name="Units", items=[("AUTO", "Auto", "As the file declares (mm detected)"),
                                                     ("m", "m", "Metres"), ("mm", "mm", "Millimetres")],
                               default="AUTO")
    skinned_path: StringProperty(name="File", subtype="FILE_PATH", description="The skinned robot to write")
    skin_robot_dir: StringProperty(name="Folder", subtype="DIR_PATH",
                                   description="Skin Whole Robot writes the links' layouts, the skinned robot "
                                               "(URDF, MJCF) and report.md here")
    skinned_format: EnumProperty(name="Format", items=[("urdf", "URDF", "One fixed frame per taxel"),
                                                        ("mjcf", "MJCF", "Sites and touch sensors")], default="urdf")
    skinned_prefix: StringProperty(name="Prefix", default="",
                                   description="Start of the taxel names (empty: LINK_vtskin_; {link} for the link)")
    skinned_footprint: EnumProperty(name="Footprint", items=[
        ("taxel", "Taxel", "Sites of the taxel's size: contacts between taxels read nothing"),
        ("tile", "Tile", "Pads and sites tiling the skin: every contact is counted")], default="taxel")
    skinned_pad: BoolProperty(name="Pads", default=False, description="MJCF: contact pads under the sites")

    # Replay
    recording_file: StringProperty(name="Recording", subtype="FILE_PATH",
                                   description="A CAN log (.log .asc .blf .trc .csv) or a CySkin text recording")
    recording_codec: EnumProperty(name="Codec", items=_CODECS, default="cyskin16")
    recording_boards: StringProperty(name="Boards", default="",
                                     description="iCub: board address of each 192-taxel block of the skin, "
                                                 "e.g. 3 or 14,13 (empty: the skin's own CAN addresses)")
    replay_rate: EnumProperty(name="Timing", items=[
        ("SCENE", "Scene rate", "Frames at the scene's frame rate, each showing the last row at or before its time"),
        ("RECORDING", "Own rate", "One frame per recorded row")], default="SCENE")
    baseline: EnumProperty(name="Baseline", items=[
        ("first", "First rows", "Median of each taxel's first received samples (iCub skinManager style)"),
        ("quiet", "Quiet window", "Median over the consecutive rows with the least variation")], default="first")
    baseline_rows: IntProperty(name="Rows", default=5, min=1, description="Rows the baseline is taken over")
    min_response: FloatProperty(name="Min response", default=0.0, min=0.0,
                                description="Counts: a frame whose strongest response is below this has no edges")

    scene_file: StringProperty(name="Scene file", subtype="FILE_PATH",
                               description="A vtcore scene (TOML) to run")
    out_dir: StringProperty(name="Output folder", subtype="DIR_PATH",
                            description="Where scene runs write their results (empty: a temporary folder)")

    # Design maps and live touch (addon/ops_evaluate.py, addon/live.py; docs/evaluate.md)
    live_touch: BoolProperty(name="Live touch", default=False, update=_live_touch_changed,
                             description="Move the indenter (or drag it) and the skin's pressure, response and "
                                         "edges follow without baking (solved on a background thread)")
    live_model: EnumProperty(name="Layer model", default="local", items=[
        ("local", "Local", "Winkler layer: fastest, no spreading between neighbouring points"),
        ("finite_layer", "Finite layer", "The layer on its rigid base (the Simulate button's model)")])
    live_note: StringProperty(name="Live touch", default="", description="Why the last live frame read zero")
    map_reference_force: FloatProperty(name="Reference force (N)", default=5.0, min=1e-3,
                                       description="Force of the localisation and two-point maps; blind where "
                                                   "a touch of this force goes unnoticed")
    map_spacing: FloatProperty(name="Spacing", default=0.002, min=2e-4, subtype="DISTANCE", unit="LENGTH",
                               description="Distance between evaluated points")
    map_margin: FloatProperty(name="Margin", default=0.01, min=0.0, subtype="DISTANCE", unit="LENGTH",
                              description="Surface evaluated beyond the part the skin covers")
    map_probe: EnumProperty(name="Probe", default="fingerpad", items=[
        ("fingerpad", "Finger pad", "A capsule 16 mm wide, 40 mm long: the footprint of a finger on CySkin"),
        ("sphere", "Fingertip", "A ball of radius 8 mm")])
    map_two_point: BoolProperty(name="Two-point map", default=True,
                                description="Also map the two-point discrimination distance (slower)")
    map_show: EnumProperty(name="Show", default="threshold", update=_map_show_changed, items=[
        ("threshold", "Detection threshold", "Smallest force felt (N)"),
        ("localisation", "Localisation error", "Expected error of the contact position (mm)"),
        ("two_point", "Two-point distance", "Separation at which two fingers are told apart (mm)")])


CLASSES = (VTSKIN_PG_object, VTSKIN_PG_scene)


def register_props():
    bpy.types.Object.vtskin = PointerProperty(type=VTSKIN_PG_object)
    bpy.types.Scene.vtskin = PointerProperty(type=VTSKIN_PG_scene)


def unregister_props():
    del bpy.types.Scene.vtskin
    del bpy.types.Object.vtskin
