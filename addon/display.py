"""Drawing taxels: a geometry-nodes modifier that puts a 4 mm disc on every taxel.

Each disc is oriented along the taxel's ``normal`` attribute and coloured by a
chosen attribute through a colour ramp (normalised by the attribute's min/max on
the object); a colour attribute such as ``tactile_color`` is used as is. The
colour is stored on the points as ``vtskin_display`` and read by the material
through an Attribute node of type *Instancer*. The skin mesh itself is kept and
drawn as thin tubes along its edges.
"""

from __future__ import annotations

import bpy

GROUP = "vtskin taxel discs"
MATERIAL = "vtskin taxel"
MODIFIER = "vtskin discs"
DISPLAY_ATTR = "vtskin_display"
DISC_RADIUS = 2e-3  # m: 4 mm discs, the CySkin taxel size
DISC_LIFT = 3e-4  # m: discs drawn this far above the taxel along its normal
EDGE_RADIUS = 2e-4  # m: skin-mesh edges drawn as tubes of this radius
EDGE_MATERIAL = "vtskin skin edge"
EDGE_SPAN_ATTR = "vtskin_edge_span"  # edge domain: vertex 2 - vertex 1 of each skin-mesh edge


def _socket(group, name, in_out, socket_type, default=None):
    s = group.interface.new_socket(name, in_out=in_out, socket_type=socket_type)
    if default is not None:
        s.default_value = default
    return s


def node_group():
    """The (shared) geometry-nodes group, built once per file: each taxel's colour, a disc on
    every taxel, and the skin mesh's edges as tubes, joined."""
    ng = bpy.data.node_groups.get(GROUP)
    if ng is not None:
        return ng
    ng = bpy.data.node_groups.new(GROUP, "GeometryNodeTree")
    _socket(ng, "Geometry", "INPUT", "NodeSocketGeometry")
    _socket(ng, "Attribute", "INPUT", "NodeSocketString", "response")
    _socket(ng, "Is colour", "INPUT", "NodeSocketBool", False)
    _socket(ng, "Radius", "INPUT", "NodeSocketFloat", DISC_RADIUS)
    _socket(ng, "Geometry", "OUTPUT", "NodeSocketGeometry")
    n, link = ng.nodes, ng.links.new
    gin = n.new("NodeGroupInput")
    gout = n.new("NodeGroupOutput")
    colour_nodes = _colour_nodes(n, link, gin)
    disc_nodes = _disc_nodes(n, link, gin, colour_nodes[-1])
    setpos, inst = disc_nodes[-2], disc_nodes[-1]
    tube_nodes = _edge_tube_nodes(n, link, setpos)

    join = n.new("GeometryNodeJoinGeometry")
    link(inst.outputs["Instances"], join.inputs["Geometry"])
    link(tube_nodes[-1].outputs["Instances"], join.inputs["Geometry"])
    link(join.outputs["Geometry"], gout.inputs["Geometry"])
    for i, node in enumerate((gin, *colour_nodes, *disc_nodes, *tube_nodes, join, gout)):
        node.location = (200 * i, 0)
    return ng


def _colour_nodes(n, link, gin) -> tuple:
    """The colour of each taxel, stored on the points as ``DISPLAY_ATTR``: the named attribute
    through the viridis ramp (normalised by its min/max), or as is when it is a colour. Returns
    the nodes in the order they are laid out, the store node last."""
    value = n.new("GeometryNodeInputNamedAttribute")
    value.data_type = "FLOAT"
    link(gin.outputs["Attribute"], value.inputs["Name"])
    stats = n.new("GeometryNodeAttributeStatistic")
    stats.data_type = "FLOAT"
    stats.domain = "POINT"
    link(gin.outputs["Geometry"], stats.inputs["Geometry"])
    link(value.outputs["Attribute"], stats.inputs["Attribute"])
    norm = n.new("ShaderNodeMapRange")
    link(value.outputs["Attribute"], norm.inputs["Value"])
    link(stats.outputs["Min"], norm.inputs["From Min"])
    link(stats.outputs["Max"], norm.inputs["From Max"])
    ramp = n.new("ShaderNodeValToRGB")
    ramp.name = "Ramp"
    _viridis(ramp.color_ramp)
    link(norm.outputs["Result"], ramp.inputs["Fac"])

    colour = n.new("GeometryNodeInputNamedAttribute")
    colour.data_type = "FLOAT_COLOR"
    link(gin.outputs["Attribute"], colour.inputs["Name"])
    switch = n.new("GeometryNodeSwitch")
    switch.input_type = "RGBA"
    link(gin.outputs["Is colour"], switch.inputs["Switch"])
    link(ramp.outputs["Color"], switch.inputs["False"])
    link(colour.outputs["Attribute"], switch.inputs["True"])

    store = n.new("GeometryNodeStoreNamedAttribute")
    store.data_type = "FLOAT_COLOR"
    store.domain = "POINT"
    store.inputs["Name"].default_value = DISPLAY_ATTR
    link(gin.outputs["Geometry"], store.inputs["Geometry"])
    link(switch.outputs["Output"], store.inputs["Value"])
    return value, stats, norm, ramp, colour, switch, store


def _disc_nodes(n, link, gin, store) -> tuple:
    """A disc of the group's radius on every taxel point of ``store``'s geometry, along its normal,
    lifted off the surface. Returns the nodes in layout order, ending with the set-position node
    (the lifted geometry) and the discs' instance node."""
    circle = n.new("GeometryNodeMeshCircle")
    circle.fill_type = "NGON"
    circle.inputs["Vertices"].default_value = 16
    link(gin.outputs["Radius"], circle.inputs["Radius"])
    setmat = n.new("GeometryNodeSetMaterial")
    setmat.inputs["Material"].default_value = material()
    link(circle.outputs["Mesh"], setmat.inputs["Geometry"])

    normal = n.new("GeometryNodeInputNamedAttribute")
    normal.data_type = "FLOAT_VECTOR"
    normal.inputs["Name"].default_value = "normal"
    # Rotation-socket node (Blender 4.2+); the Euler variant is deprecated.
    align = n.new("FunctionNodeAlignRotationToVector")
    align.axis = "Z"
    link(normal.outputs["Attribute"], align.inputs["Vector"])

    # Discs float a little above the surface so they do not z-fight with it.
    lift = n.new("ShaderNodeVectorMath")
    lift.operation = "SCALE"
    link(normal.outputs["Attribute"], lift.inputs[0])
    lift.inputs["Scale"].default_value = DISC_LIFT
    setpos = n.new("GeometryNodeSetPosition")
    link(store.outputs["Geometry"], setpos.inputs["Geometry"])
    link(lift.outputs["Vector"], setpos.inputs["Offset"])

    # Only taxel points get discs: the skin mesh's vertices ARE the taxels.
    inst = n.new("GeometryNodeInstanceOnPoints")
    link(setpos.outputs["Geometry"], inst.inputs["Points"])
    link(setmat.outputs["Geometry"], inst.inputs["Instance"])
    link(align.outputs["Rotation"], inst.inputs["Rotation"])
    return circle, setmat, normal, align, lift, setpos, inst


def _edge_tube_nodes(n, link, setpos) -> tuple:
    """The skin mesh's edges as thin dark tubes (faces would z-fight with the surface): one
    instanced cylinder per edge, at its midpoint, along it, as long as it. Not Mesh to Curve +
    Curve to Mesh: that realises every tube on every frame, which cost 3/4 of the playback
    time of a 4,000-taxel skin (about 12,000 edges); instances are drawn, not built. Returns the
    nodes in layout order, the tubes' instance node last."""
    edge_vec = n.new("GeometryNodeInputMeshEdgeVertices")
    span = n.new("ShaderNodeVectorMath")
    span.operation = "SUBTRACT"
    link(edge_vec.outputs["Position 2"], span.inputs[0])
    link(edge_vec.outputs["Position 1"], span.inputs[1])
    store_span = n.new("GeometryNodeStoreNamedAttribute")
    store_span.data_type = "FLOAT_VECTOR"
    store_span.domain = "EDGE"
    store_span.inputs["Name"].default_value = EDGE_SPAN_ATTR
    link(setpos.outputs["Geometry"], store_span.inputs["Geometry"])
    link(span.outputs["Vector"], store_span.inputs["Value"])
    mids = n.new("GeometryNodeMeshToPoints")
    mids.mode = "EDGES"
    link(store_span.outputs["Geometry"], mids.inputs["Mesh"])
    span_pt = n.new("GeometryNodeInputNamedAttribute")
    span_pt.data_type = "FLOAT_VECTOR"
    span_pt.inputs["Name"].default_value = EDGE_SPAN_ATTR
    along = n.new("FunctionNodeAlignRotationToVector")
    along.axis = "Z"
    link(span_pt.outputs["Attribute"], along.inputs["Vector"])
    length = n.new("ShaderNodeVectorMath")
    length.operation = "LENGTH"
    link(span_pt.outputs["Attribute"], length.inputs[0])
    scale = n.new("ShaderNodeCombineXYZ")
    scale.inputs["X"].default_value = 1.0
    scale.inputs["Y"].default_value = 1.0
    link(length.outputs["Value"], scale.inputs["Z"])
    rod = n.new("GeometryNodeMeshCylinder")
    rod.fill_type = "NONE"
    rod.inputs["Vertices"].default_value = 6
    rod.inputs["Radius"].default_value = EDGE_RADIUS
    rod.inputs["Depth"].default_value = 1.0
    wire_mat = n.new("GeometryNodeSetMaterial")
    wire_mat.inputs["Material"].default_value = edge_material()
    link(rod.outputs["Mesh"], wire_mat.inputs["Geometry"])
    tubes = n.new("GeometryNodeInstanceOnPoints")
    link(mids.outputs["Points"], tubes.inputs["Points"])
    link(wire_mat.outputs["Geometry"], tubes.inputs["Instance"])
    link(along.outputs["Rotation"], tubes.inputs["Rotation"])
    link(scale.outputs["Vector"], tubes.inputs["Scale"])
    return edge_vec, span, store_span, mids, span_pt, along, length, scale, rod, wire_mat, tubes


def _viridis(ramp):
    stops = [(0.0, (0.267, 0.005, 0.329, 1)), (0.25, (0.229, 0.322, 0.546, 1)),
             (0.5, (0.128, 0.567, 0.551, 1)), (0.75, (0.369, 0.789, 0.383, 1)),
             (1.0, (0.993, 0.906, 0.144, 1))]
    els = ramp.elements
    els[0].position, els[0].color = stops[0]
    els[1].position, els[1].color = stops[-1]
    for pos, col in stops[1:-1]:
        e = els.new(pos)
        e.color = col


def shader_nodes(mat):
    """The shader node tree of material (or world) ``mat``. Blender 5.x gives every new material
    and world one (``use_nodes`` is deprecated there, to go in 6.0); 4.x makes it only when
    ``use_nodes`` is switched on."""
    if mat.node_tree is None:
        mat.use_nodes = True
    return mat.node_tree


def set_modifier_input(mod, identifier: str, value):
    """Set input ``identifier`` (``Socket_N``) of geometry-nodes modifier ``mod`` to ``value``.

    The one place where the add-on's Blender versions differ: up to 5.1 the inputs are ID
    properties of the modifier (``mod[identifier]``); 5.2 refuses ID properties there and
    exposes them as ``mod.properties.inputs.<identifier>.value``. Which one is present is
    tested, not the version number.
    """
    props = getattr(mod, "properties", None)
    if props is None:
        mod[identifier] = value
    else:
        getattr(props.inputs, identifier).value = value


def material():
    """The material of the discs: the ``vtskin_display`` colour, emissive enough to read."""
    mat = bpy.data.materials.get(MATERIAL)
    if mat is not None:
        return mat
    mat = bpy.data.materials.new(MATERIAL)
    nt = shader_nodes(mat)
    bsdf = nt.nodes.get("Principled BSDF")
    attr = nt.nodes.new("ShaderNodeAttribute")
    attr.attribute_type = "INSTANCER"
    attr.attribute_name = DISPLAY_ATTR
    attr.location = (-400, 0)
    nt.links.new(attr.outputs["Color"], bsdf.inputs["Base Color"])
    nt.links.new(attr.outputs["Color"], bsdf.inputs["Emission Color"])
    bsdf.inputs["Emission Strength"].default_value = 0.3
    mat.diffuse_color = (0.8, 0.8, 0.8, 1.0)
    return mat


#: the face colour attribute of an imported link's exposure, and the material that shows it
EXPOSURE_ATTR = "vtskin_exposure"
EXPOSURE_MATERIAL = "VTSkin exposure"


def exposure_material():
    """The material of imported links: the face colours of ``vtskin_exposure`` (the exposed surface)."""
    mat = bpy.data.materials.get(EXPOSURE_MATERIAL)
    if mat is not None:
        return mat
    mat = bpy.data.materials.new(EXPOSURE_MATERIAL)
    nt = shader_nodes(mat)
    attr = nt.nodes.new("ShaderNodeAttribute")
    attr.attribute_name = EXPOSURE_ATTR
    attr.location = (-400, 0)
    nt.links.new(attr.outputs["Color"], nt.nodes.get("Principled BSDF").inputs["Base Color"])
    return mat


def show_exposure(mesh, colours) -> None:
    """Colour ``mesh``'s faces by ``colours`` ((F, 4) RGBA) through :func:`exposure_material`."""
    from . import bridge

    bridge.set_attribute(mesh, EXPOSURE_ATTR, colours, "FLOAT_COLOR", "FACE")
    if EXPOSURE_MATERIAL not in mesh.materials:
        mesh.materials.append(exposure_material())


def edge_material():
    """Dark material of the skin-mesh edge tubes."""
    mat = bpy.data.materials.get(EDGE_MATERIAL)
    if mat is None:
        mat = bpy.data.materials.new(EDGE_MATERIAL)
        bsdf = shader_nodes(mat).nodes.get("Principled BSDF")
        bsdf.inputs["Base Color"].default_value = (0.05, 0.05, 0.06, 1.0)
        mat.diffuse_color = (0.05, 0.05, 0.06, 1.0)
    return mat


def ensure_display(ob):
    """Add (once) the disc modifier to taxel object ``ob`` and colour by its setting."""
    mod = ob.modifiers.get(MODIFIER)
    if mod is None:
        mod = ob.modifiers.new(MODIFIER, "NODES")
        mod.node_group = node_group()
    set_color_by(ob, ob.vtskin.color_by)
    return mod


def ramp_node(ob):
    """The colour-ramp node the taxel discs of ``ob`` are coloured through (the panel draws it as
    the legend's colour bar), or None."""
    mod = ob.modifiers.get(MODIFIER) if ob is not None else None
    if mod is None or mod.node_group is None:
        return None
    return mod.node_group.nodes.get("Ramp")


def legend_lines(ob) -> list:
    """What the colours of ``ob``'s taxels mean: quantity, unit and the range the ramp spans (the
    ramp is scaled to the attribute's min and max on the object): ``vtcore.plots.legend_lines``."""
    from vtcore.plots import legend_lines as words

    from . import bridge

    name = ob.vtskin.color_by
    attr = ob.data.attributes.get(name) if ob.type == "MESH" else None
    if attr is None:
        return [f"{name}: not on this skin yet"]
    if attr.data_type in ("FLOAT_COLOR", "BYTE_COLOR"):
        return [f"{name}: the colours as stored"]
    return words(name, bridge.get_attribute(ob.data, name))


_ID_HANDLE = None


def draw_ids():
    """Viewport overlay (POST_PIXEL): each taxel's id next to it, on skins with *Show taxel ids*."""
    import blf
    from bpy_extras.view3d_utils import location_3d_to_region_2d

    from . import bridge

    context = bpy.context
    region, rv3d = context.region, context.region_data
    if region is None or rv3d is None:
        return
    for ob in context.visible_objects:
        s = getattr(ob, "vtskin", None)
        if s is None or s.role != "TAXELS" or not s.show_ids or "taxel_id" not in ob.data.attributes:
            continue
        m = bridge.matrix(ob)
        pts = bridge.vertex_positions(ob.data).reshape(-1, 3) @ m[:3, :3].T + m[:3, 3]
        ids = bridge.get_attribute(ob.data, "taxel_id")
        blf.size(0, 11)
        for p, i in zip(pts[:4000], ids[:4000]):  # a label per taxel: a few thousand at most stay readable
            xy = location_3d_to_region_2d(region, rv3d, p)
            if xy is not None:
                blf.position(0, xy[0] + 4, xy[1] + 4, 0)
                blf.draw(0, str(int(i)))


def register_ids():
    global _ID_HANDLE
    if _ID_HANDLE is None and not bpy.app.background:
        _ID_HANDLE = bpy.types.SpaceView3D.draw_handler_add(draw_ids, (), "WINDOW", "POST_PIXEL")


def unregister_ids():
    global _ID_HANDLE
    if _ID_HANDLE is not None:
        bpy.types.SpaceView3D.draw_handler_remove(_ID_HANDLE, "WINDOW")
        _ID_HANDLE = None


def set_color_by(ob, name: str):
    """Colour the discs of ``ob`` by attribute ``name`` (ramp for scalars, as is for colours)."""
    mod = ob.modifiers.get(MODIFIER)
    if mod is None:
        return
    ng = mod.node_group
    ids = {s.name: s.identifier for s in ng.interface.items_tree if s.item_type == "SOCKET" and s.in_out == "INPUT"}
    set_modifier_input(mod, ids["Attribute"], name)
    attr = ob.data.attributes.get(name) if ob.type == "MESH" else None
    is_colour = attr is not None and attr.data_type in ("FLOAT_COLOR", "BYTE_COLOR")
    set_modifier_input(mod, ids["Is colour"], is_colour)
    ob.data.update()
