"""Scene sections: choices are the core's own option sets; defaults need no validation context."""

from __future__ import annotations

import pytest

from vtcore.contact import elastic, proximity
from vtcore.contact.press import GEOMETRIES
from vtcore.scene import load_scene
from vtcore.scene.registry import EFFECTS, discover
from vtcore.scene.schema import Field, Section
from vtcore.scene.sections.layer import DEFAULTS as LAYER_DEFAULTS
from vtcore.scene.sections.layer import LAYER, build_layer, layer_options


def test_layer_choices_are_the_contact_packages_constants():
    discover()
    assert LAYER.fields["model"].choices is elastic.MODELS
    assert LAYER.fields["base"].choices is elastic.BASES
    assert LAYER.fields["geometry"].choices is GEOMETRIES
    assert LAYER.fields["backend"].choices == ("auto",) + proximity.BACKENDS
    assert EFFECTS["soft_layer"].params.fields["kernel"].choices is elastic.SPREADINGS


def test_every_contact_model_is_a_valid_scene_value(tmp_path):
    for model in elastic.MODELS:
        p = tmp_path / f"{model}.toml"
        p.write_text(f'[scene]\ntask = "press"\n[layer]\nmodel = "{model}"\n[[objects]]\nkind = "sphere"\n')
        assert layer_options(load_scene(p))["model"] == model


def test_defaults_are_the_fields_defaults_and_not_shared():
    sec = Section({"a": Field("float", default=1.5), "v": Field("vec", default=[0.0, 1.0], length=2)})
    d = sec.defaults()
    assert d == {"a": 1.5, "v": [0.0, 1.0]}
    d["v"].append(2.0)
    assert sec.defaults()["v"] == [0.0, 1.0]
    with pytest.raises(ValueError, match="t required"):
        Section({"t": Field("float")}).defaults()


def test_a_scene_without_a_layer_table_gets_the_default_layer(tmp_path):
    p = tmp_path / "s.toml"
    p.write_text('[scene]\ntask = "press"\n[[objects]]\nkind = "sphere"\n')
    scene = load_scene(p)
    layer = build_layer(scene)
    # no key and no [layer] profile: the layer section's stated defaults (3 mm)
    assert layer.thickness == LAYER_DEFAULTS["thickness"] == 0.003
    assert layer_options(scene)["geometry"] == "plane"
