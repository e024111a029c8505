"""Analysis operators: edges on the skin's response, augmented point-cloud colours."""

from __future__ import annotations

import bpy
import numpy as np

from . import bridge, display, skin
from .opbase import Cancel, Op, failing, need_skin

class VTSKIN_OT_edges(Op, bpy.types.Operator):
    """Run the edge filter on the skin's response and show the edge taxels"""

    bl_idname = "vtskin.edges"
    bl_label = "Detect Edges"

    show: bpy.props.BoolProperty(name="Show edges", default=True, description="Colour the taxels by edge")

    def run(self, context):
        from vtcore.scene import interactive

        ob = need_skin(context, "Select a skin with a response (simulate a contact first)", taxels=True,
                        attribute="response")
        response = bridge.get_attribute(ob.data, "response").astype(np.float64)
        with failing("Edge filter failed"):
            er, edge = interactive.edges(skin.read_layout(ob), skin.triangles(ob), response,
                                         context.scene.vtskin.edge_fraction)
        bridge.set_attribute(ob.data, "edge_response", er, "FLOAT")
        bridge.set_attribute(ob.data, "edge", edge)
        if self.show:
            ob.vtskin.color_by = "edge"
        display.ensure_display(ob)
        self.report({"INFO"}, f"{int(edge.sum())} edge taxels")
        return {"FINISHED"}


class VTSKIN_OT_augment(Op, bpy.types.Operator):
    """Propagate probe values over the point cloud (cluster or smooth) and colour it"""

    bl_idname = "vtskin.augment"
    bl_label = "Augment Point Cloud"

    def run(self, context):
        from vtcore.scene import interactive

        s = context.scene.vtskin
        cloud = s.cloud
        if cloud is None or cloud.type != "MESH" or len(cloud.data.vertices) == 0:
            raise Cancel("Choose a point-cloud object (a mesh with vertices) in the panel")
        if cloud.mode == "EDIT":
            cloud.update_from_editmode()
        me = cloud.data
        pts = bridge.vertex_positions(me, bridge.matrix(cloud))
        n = len(pts)
        with failing("Augmentation failed"):
            if s.probe_source == "FILE":
                probes, values = interactive.probes_from_file(bpy.path.abspath(s.probe_file))
            else:
                sel = bridge.selected_vertices(me)
                if len(sel) == 0:
                    raise Cancel(f"No vertices of {cloud.name!r} are selected as probes")
                if s.probe_attribute not in me.attributes:
                    raise Cancel(f"{cloud.name!r} has no attribute {s.probe_attribute!r} with probe values")
                probes = pts[sel]
                values = bridge.get_attribute(me, s.probe_attribute).astype(np.float64)
                if values.ndim != 1:
                    raise Cancel(f"Attribute {s.probe_attribute!r} must be a float attribute")
                values = values[sel]
            vals, rgb = interactive.augment(pts, probes, values, method=s.propagation, beta=s.beta)
        bridge.set_attribute(me, "tactile_value", vals, "FLOAT")
        bridge.set_attribute(me, "tactile_color", rgb, "FLOAT_COLOR")
        me.color_attributes.active_color_name = "tactile_color"
        cloud.vtskin.role = "CLOUD"
        cloud.vtskin.color_by = "tactile_color"
        display.ensure_display(cloud)
        self.report({"INFO"}, f"Coloured {n} points from {len(probes)} probes")
        return {"FINISHED"}


CLASSES = (VTSKIN_OT_edges, VTSKIN_OT_augment)
