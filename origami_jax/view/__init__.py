"""Interactive 3D views of origami in a web browser or a notebook: turn, zoom, scrub through time.

```python
from origami_jax import view

view.show(result)                                 # in a notebook: an inline view
view.write_html(trajectory, "fold.html", system=system)   # one self-contained page
```

A **scene** (`Scene`) is the plain data a view draws: frames of rigid panels (world-frame polygons),
hinge segments with a fold angle per frame, panel thickness, contacts and a verdict. `scene_from`
builds one from a FOLD file with frames, an unfolding result, a simulated trajectory (with its
system, or its pattern), a pattern (`Net`, `CreasePattern`, `Accordion`: flat and folded as
intended), a folding system or mechanism, a sweep member, or the result files of the command line
(`origami-jax view RESULT` writes the page). Results with many samples are shown as at most
`DEFAULT_MAX_FRAMES` frames evenly spaced in time (`resample`).

The page inlines three.js (r185, from its npm release, MIT licence; `static/`): it needs no network
and no install. This sub-package imports no JAX until an adapter needs the physics.
"""

from ._adapters import PATTERN_FRAMES as PATTERN_FRAMES
from ._adapters import scene_from_mechanism as scene_from_mechanism
from ._adapters import scene_from_pattern as scene_from_pattern
from ._adapters import scene_from_trajectory as scene_from_trajectory
from ._adapters import scene_from_unfolding as scene_from_unfolding
from ._adapters import scene_from_vertex_path as scene_from_vertex_path
from ._fold_scene import fold_crease_pattern as fold_crease_pattern
from ._fold_scene import scene_from_fold as scene_from_fold
from ._html import THREE_VERSION as THREE_VERSION
from ._html import View as View
from ._html import open_in_browser as open_in_browser
from ._html import scene_payload as scene_payload
from ._html import show as show
from ._html import to_html as to_html
from ._html import write_html as write_html
from ._scene import DEFAULT_MAX_FRAMES as DEFAULT_MAX_FRAMES
from ._scene import Scene as Scene
from ._scene import frame_indices as frame_indices
from ._scene import resample as resample
from ._scene import scene_from_polygons as scene_from_polygons
from ._scene import triangulate as triangulate
from ._sources import load_scene as load_scene
from ._sources import scene_from as scene_from
from ._sources import scene_from_sweep_member as scene_from_sweep_member
from ._sources import simulated_pattern as simulated_pattern
from ._sources import sweep_member_pattern as sweep_member_pattern
from ._sources import sweep_member_system as sweep_member_system
