"""Pages for the Meshcat replays: one small page per replay that loads the viewer code from a
shared `meshcat.js` beside it, and one self-contained gallery of every replay (the viewer code
once, compressed) small enough for the Snakemake report, which embeds each result as a data URI
and Chromium opens none over 2 MiB.

A scene (roboball.sim.replay.Scene, stored as JSON) holds Meshcat's commands, the camera and
what ran; the pages replay the commands, put the camera beside the robot and move it with the
robot, so that the whole run stays in view.
"""
from __future__ import annotations

import base64
import gzip
import json
import math

import jinja2

from roboball.errors import RoboballError

# Chromium refuses URLs over 2 MiB (url::kMaxURLChars); the Snakemake report's data URIs are
# its results in base64 behind a short header.
DATA_URI_LIMIT = 2 * 1024 * 1024
_URI_HEADER = len("data:text/html;charset=utf8;filename=index.html;base64,")

_KINDS = {"ramp": "Ramp descent", "shell_rock": "Shell rocking on the floor (steer locked)",
          "steer_stand": "Steer pendulum on the stand", "drive_stand": "Drive pendulum on the stand"}

# The viewer set-up shared by both pages: replay the commands, light background, camera from
# the side, and a render callback that moves camera and target with the robot (the user can
# still orbit and zoom: only the robot's displacement is added).
_BOOT_JS = """
function b64bytes(b64) { return Uint8Array.from(atob(b64), c => c.charCodeAt(0)); }
function roboballReplay(el, scene) {
  const viewer = new MeshCat.Viewer(el);
  viewer.set_property(['Background', '<object>'], 'top_color', [.95, .95, 1.0]);
  viewer.set_property(['Background', '<object>'], 'bottom_color', [.62, .66, .72]);
  // Drake's own page boosts the decaying lights; the scenery spans metres, so more ambient light
  const light = (name, v) => viewer.set_property(['Lights', name, '<object>'], 'intensity', v);
  light('SpotLight', 30); light('PointLightNegativeX', 25); light('PointLightPositiveX', 25);
  light('AmbientLight', 0.9); light('FillLight', 0.8);
  viewer.set_property(['Axes'], 'visible', false);
  for (const c of scene.commands) viewer.handle_command_bytearray(b64bytes(c));
  const yup = p => [p[0], p[2], -p[1]];          // Meshcat's camera frame is y-up
  viewer.set_property(['Cameras', 'default', 'rotated', '<object>'], 'position', yup(scene.camera_m));
  viewer.set_camera_target(yup(scene.target_m));
  viewer.gui.close();
  const body = viewer.scene_tree.find(scene.follow.split('/').filter(s => s)).object;
  let last = null;
  viewer.render_callback = () => {
    const p = viewer.camera.parent.worldToLocal(body.getWorldPosition(viewer.camera.position.clone()));
    if (last) {
      const d = p.clone().sub(last);
      viewer.camera.position.add(d);
      viewer.controls.target.add(d);
    }
    last = p;
  };
  return viewer;
}
"""

_CSS = """
body { margin: 0; font-family: sans-serif; background: #20242a; color: #eee; }
.caption { font-size: 14px; line-height: 1.35; padding: 6px 10px; background: rgba(20, 24, 30, 0.82); }
.caption b { color: #fff; }
"""

_STANDALONE = jinja2.Template("""<!doctype html>
<html><head><meta charset="utf-8"><title>{{ title|e }}</title>
<style>{{ css }}
#pane { position: fixed; inset: 0; }
.caption { position: fixed; left: 0; top: 0; max-width: 60%; z-index: 2; }
</style></head>
<body>
<div id="pane"></div>
<div class="caption"><b>{{ title|e }}</b><br>{{ caption|e }}</div>
<script src="meshcat.js"></script>
<script>
{{ boot }}
const SCENE = {{ scene_json }};
if (typeof MeshCat === 'undefined') {
  document.querySelector('.caption').innerHTML += '<br><b>meshcat.js</b> (the viewer code) was not found beside this file.';
} else {
  roboballReplay(document.getElementById('pane'), SCENE);
}
</script>
</body></html>
""", autoescape=False)

_GALLERY = jinja2.Template("""<!doctype html>
<html><head><meta charset="utf-8"><title>roboball: Meshcat replays</title>
<style>{{ css }}
.grid { display: grid; grid-template-columns: 1fr 1fr; gap: 6px; padding: 6px; }
.cell { background: #333; }
.frame { position: relative; height: 38vh; min-height: 280px; }
.view { position: absolute; inset: 0; }
h1 { font-size: 17px; margin: 8px 10px 0; }
p.note { font-size: 13px; margin: 2px 10px; color: #ccc; }
</style></head>
<body>
<h1>Meshcat replays of simulated runs</h1>
<p class="note">Each plays in a loop; drag to orbit, scroll to zoom. The camera follows the robot.</p>
<div class="grid">
{% for s in scenes %}<div class="cell"><div class="frame"><div class="view" id="view{{ loop.index0 }}"></div></div>
<div class="caption"><b>{{ s.title|e }}</b><br>{{ s.caption|e }}</div></div>
{% endfor %}</div>
<script type="application/octet-stream" id="viewer-gz">{{ viewer_gz }}</script>
<script type="application/octet-stream" id="scenes-gz">{{ scenes_gz }}</script>
<script>
{{ boot }}
async function inflate(id) {
  const bytes = b64bytes(document.getElementById(id).textContent.trim());
  const stream = new Blob([bytes]).stream().pipeThrough(new DecompressionStream('gzip'));
  return await new Response(stream).text();
}
(async () => {
  (0, eval)(await inflate('viewer-gz'));          // defines MeshCat globally, as a <script> would
  const scenes = JSON.parse(await inflate('scenes-gz'));
  scenes.forEach((s, i) => roboballReplay(document.getElementById('view' + i), s));
})();
</script>
</body></html>
""", autoescape=False)


def caption(facts: dict) -> tuple[str, str]:
    """(title, caption) of a replay from what ran, e.g. ("Ramp descent", "hydroelastic contact;
    shell at 13.8 kPa ...")."""
    kind = facts["kind"]
    on_stand = kind in ("steer_stand", "drive_stand")
    parts = ["held by the stand, no ground contact" if on_stand else f"{facts['contact']} contact"]
    if facts.get("pressure_kpa") is not None and not on_stand and facts["contact"] != "point":
        shell = f"shell at {facts['pressure_kpa']:g} kPa"
        if facts.get("zeta") is not None:
            shell += (f" (damping ratio {facts['zeta']:.3g}, natural frequency {facts['omega_n_rad_s']:.3g} rad/s, "
                      "from the pipeline's shell regression)")
        parts.append(shell)
    if facts.get("dissipation_scale", 1.0) != 1.0 and facts["contact"] == "hydroelastic":
        parts.append(f"hydroelastic dissipation x {facts['dissipation_scale']:g}")
    parts.append(f"friction: {facts['friction']}")
    if kind == "ramp":
        parts.append(f"{facts['ramp_angle_deg']:g} deg ramp, {facts['ramp_length_m']:g} m long, then the floor")
    parts.append(f"released from rest at {facts['release_rad']:g} rad")
    parts.append(f"{facts['duration_s']:g} s, looping")
    return _KINDS.get(kind, kind), "; ".join(parts) + "."


def _scene_for_page(scene: dict) -> dict:
    title, text = caption(scene["facts"])
    return {**scene, "title": title, "caption": text}


def standalone_page(scene: dict) -> str:
    """One replay's page; it loads the viewer code from `meshcat.js` in its own folder."""
    s = _scene_for_page(scene)
    js_scene = {k: s[k] for k in ("commands", "camera_m", "target_m", "follow")}
    return _STANDALONE.render(title=s["title"], caption=s["caption"], css=_CSS, boot=_BOOT_JS,
                              scene_json=json.dumps(js_scene))


def _gz64(text: str) -> str:
    """gzip (no time stamp: the same input gives the same bytes) and base64."""
    return base64.b64encode(gzip.compress(text.encode("utf-8"), compresslevel=9, mtime=0)).decode("ascii")


def data_uri_length(n_bytes: int) -> int:
    """Length of the data URI the Snakemake report makes of a file of `n_bytes` bytes."""
    return _URI_HEADER + 4 * math.ceil(n_bytes / 3)


def gallery_page(scenes: list, viewer_js: str, source: str = "gallery") -> str:
    """Every replay in one self-contained page, the viewer code once (gzip, base64).

    Raises:
        RoboballError: when the page would exceed Chromium's 2 MiB data-URI limit.
    """
    pages = [_scene_for_page(s) for s in scenes]
    js_scenes = [{k: s[k] for k in ("commands", "camera_m", "target_m", "follow")} for s in pages]
    html = _GALLERY.render(scenes=pages, css=_CSS, boot=_BOOT_JS, viewer_gz=_gz64(viewer_js),
                           scenes_gz=_gz64(json.dumps(js_scenes)))
    n = len(html.encode("utf-8"))
    if data_uri_length(n) > DATA_URI_LIMIT:
        raise RoboballError(f"{source}: {n} bytes, over the 2 MiB a browser opens as a report's data URI "
                            f"(fewer or shorter replays)")
    return html
