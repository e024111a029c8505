"""vtcore: the headless core of the visuo-tactile skin toolkit.

Everything that computes lives here; the Blender add-on (``addon/``) only moves
data between Blender and these functions. ``vtcore`` never imports ``bpy``.

Sub-packages, in the direction data flows (a package imports only those to its
left): ``layout`` -> ``contact`` -> ``filters`` / ``augment`` / ``categorize`` ->
``control``; ``can`` decodes skin traffic; ``scene`` composes all of them into
runnable experiments; ``cli`` is the ``vtcore`` command.
"""

__version__ = "0.1.0"
