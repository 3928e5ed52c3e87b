"""Would a host-built Shirley-Tuchman fan beat the geometry shader?  A lower bound, measured.

Issue 44 item 3: ``integration = "shirley-tuchman"`` builds each cell's fan (class 1 or 2, the thick
vertex, 3 or 4 triangles) in ``pt.geom``, per cell.  The alternative is VTK's: build the fan on the
host (numba), in visibility order, into a vertex buffer, and draw it with a plain vertex and
fragment shader.  This bench times, interleaved per frame (A B A B ..., medians, first view of
``dvr bench cells`` at 512x512), for each shared mesh:

* ``gs draw ms``: the shipped frame's draw (``stats["draw_seconds"]``: geometry shader, rasterizer,
  fragments; the order, the same for both, left out);
* ``host ms``: the host fan for the same cells in a depth order (projection, classification, thick
  vertex, 3 or 4 triangles of 3 float32 vertices each: pixel, colour, optical depth), its upload, its
  draw with over-blending and the read-back, of which ``fan ms`` is the numba loop and ``raster ms``
  the upload-free draw and read-back.

The host fan here leaves out the exact transfer-function integral at the thick vertex and the
vertex colours (a stand-in optical depth and colour), so ``host ms`` is a lower bound on what the
real host path would cost; the covered pixel counts of both pictures are printed to show the
footprints are the same.  If ``raster ms`` alone is close to ``gs draw ms``, the geometry shader
is not where the frame goes, and the host path cannot win much.

    python dvr_gl/renderers/projected_tetrahedra/benchmarks/host_fan.py --data-dir ../shared/data
        [--meshes notch,comb,post,bluntfin,tetraMesh] [--frames 5]
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import moderngl
import numpy as np

SIZE = 512
VERTEX = """#version 330
in vec2 in_pixel;
in vec4 in_st;  // colour, optical depth
uniform vec2 u_size;
noperspective out vec4 v_st;
void main() { v_st = in_st; gl_Position = vec4(in_pixel / u_size * 2.0 - 1.0, 0.0, 1.0); }
"""
FRAGMENT = """#version 330
noperspective in vec4 v_st;
out vec4 f_colour;
void main() { float a = 1.0 - exp(-v_st.a); f_colour = vec4(v_st.rgb * a, a); }
"""


def fan_kernel():
    """The numba loop: ``fan(pixels, depth, tets, order, out) -> vertices written``; ``pixels`` (n, 2)
    the points' projections in pixels, ``depth`` their clip w, ``out`` (12 cells, 6) float32 rows x, y,
    r, g, b, optical depth; the thick vertex's stand-in optical depth is a tenth of its depth span."""
    import numba

    @numba.njit(cache=True)
    def orient(q, a, b, px, py):
        return (q[b, 0] - q[a, 0]) * (py - q[a, 1]) - (q[b, 1] - q[a, 1]) * (px - q[a, 0])

    @numba.njit(cache=True)
    def inside(q, k, a, b, c):
        x, y = q[k, 0], q[k, 1]
        u, v, w = orient(q, a, b, x, y), orient(q, b, c, x, y), orient(q, c, a, x, y)
        return (u >= 0 and v >= 0 and w >= 0) or (u <= 0 and v <= 0 and w <= 0)

    @numba.njit(cache=True)
    def put(out, n, x, y, tau):
        out[n, 0], out[n, 1], out[n, 2], out[n, 3], out[n, 4], out[n, 5] = x, y, 0.8, 0.5, 0.2, tau
        return n + 1

    @numba.njit(cache=True)
    def fan(pixels, depth, tets, order, out):
        q, z, ring = np.empty((4, 2)), np.empty(4), np.empty(4, np.int64)
        n = 0
        for c in order:
            for k in range(4):
                q[k, 0], q[k, 1], z[k] = pixels[tets[c, k], 0], pixels[tets[c, k], 1], depth[tets[c, k]]
            inner = -1
            for k in range(4):
                if inside(q, k, (k + 1) % 4, (k + 2) % 4, (k + 3) % 4):
                    inner = k
                    break
            if inner >= 0:  # class 1: the inner vertex is the thick one, 3 triangles
                tx, ty, tau, corners = q[inner, 0], q[inner, 1], 0.1 * abs(z[inner] - z[(inner + 1) % 4]), 3
                for m in range(3):
                    ring[m] = (inner + 1 + m) % 4
            else:  # class 2: the diagonals 0 j and the other two cross at the thick point, 4 triangles
                j, a, b = 1, 2, 3
                for j in range(1, 4):
                    a, b = (2, 3) if j == 1 else ((1, 3) if j == 2 else (1, 2))
                    if orient(q, 0, j, q[a, 0], q[a, 1]) * orient(q, 0, j, q[b, 0], q[b, 1]) < 0:
                        break
                ex, ey, fx, fy = q[j, 0] - q[0, 0], q[j, 1] - q[0, 1], q[b, 0] - q[a, 0], q[b, 1] - q[a, 1]
                den = ex * fy - ey * fx
                t = min(max(((q[a, 0] - q[0, 0]) * fy - (q[a, 1] - q[0, 1]) * fx) / den, 0.0), 1.0) if den != 0 else 0.5
                tx, ty, tau, corners = q[0, 0] + ex * t, q[0, 1] + ey * t, 0.1 * abs(z[0] - z[j]), 4
                ring[0], ring[1], ring[2], ring[3] = 0, a, j, b
            for m in range(corners):
                u, v = ring[m], ring[(m + 1) % corners]
                n = put(out, n, tx, ty, tau)
                n = put(out, n, q[u, 0], q[u, 1], 0.0)
                n = put(out, n, q[v, 0], q[v, 1], 0.0)
        return n

    return fan


def measure(pt, name: str, data_dir: Path, frames: int) -> dict:
    """One mesh's row: the shipped draw and the host fan's parts (ms, medians), their covered pixels."""
    from dvr_gl.bench.datasets import MESHES, mesh_scene_keys
    from dvr_gl.gl.geometry import projection_matrix, view_matrix
    from dvr_gl.scene.resolve import load_scene

    source, array = MESHES[name]
    path = data_dir / source
    mesh = load_scene(None, {"volume.path": str(path), **({"volume.array": array} if array else {})}).field
    scene = load_scene(None, {**mesh_scene_keys(path, array, mesh), "camera.azimuth": 30.0, "camera.elevation": 20.0,
                              "renderer.name": "projected-tetrahedra", "image.width": SIZE, "image.height": SIZE})
    scene = scene.with_renderer(cell_order="exact", integration="shirley-tuchman")
    shipped = pt.render(scene)  # upload, programs, adjacency: untimed
    cam, ctx = scene.camera, pt.ctx
    clip = np.c_[mesh.points, np.ones(len(mesh.points))] @ (projection_matrix(cam, 1.0, cam.near, 1e6)
                                                             @ view_matrix(cam)).T
    pixels, depth = (clip[:, :2] / clip[:, 3:] * 0.5 + 0.5) * SIZE, clip[:, 3].copy()
    tets = np.asarray(mesh.tets, np.int64)
    order = np.argsort(-depth[tets].mean(axis=1)).astype(np.int64)  # back to front (a stand-in order)
    out = np.empty((12 * len(tets), 6), np.float32)
    fan = fan_kernel()
    fan(pixels, depth, tets, order[:4], out)  # compiled: untimed
    program = ctx.program(vertex_shader=VERTEX, fragment_shader=FRAGMENT)
    program["u_size"] = (SIZE, SIZE)
    fbo = ctx.simple_framebuffer((SIZE, SIZE), components=4, dtype="f4")
    times = {"gs draw ms": [], "host ms": [], "fan ms": [], "raster ms": []}
    for _ in range(frames):
        pt.render(scene)
        times["gs draw ms"].append(pt.stats["draw_seconds"])
        start = time.perf_counter()
        n = fan(pixels, depth, tets, order, out)
        built = time.perf_counter()
        buffer = ctx.buffer(out[:n])
        vao = ctx.vertex_array(program, [(buffer, "2f 4f", "in_pixel", "in_st")])
        uploaded = time.perf_counter()
        fbo.use()
        fbo.clear()
        ctx.enable(moderngl.BLEND)
        ctx.blend_func = (moderngl.ONE, moderngl.ONE_MINUS_SRC_ALPHA)
        vao.render(moderngl.TRIANGLES, vertices=n)
        image = np.frombuffer(fbo.read(components=4, dtype="f4"), np.float32).reshape(SIZE, SIZE, 4)
        done = time.perf_counter()
        ctx.disable(moderngl.BLEND)
        vao.release()
        buffer.release()
        for key, seconds in (("host ms", done - start), ("fan ms", built - start), ("raster ms", done - uploaded)):
            times[key].append(seconds)
    row = {key: 1e3 * statistics.median(values) for key, values in times.items()}
    row.update(mesh=name, cells=len(tets), triangles=n // 3, covered=(int((shipped[..., 3] > 1e-4).sum()),
                                                                       int((image[..., 3] > 1e-4).sum())))
    return row


def main(argv=None):
    from dvr_gl.renderers import create_renderer

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data-dir", type=Path, required=True, help="the shared data folder")
    parser.add_argument("--meshes", default="notch,comb,post,bluntfin,tetraMesh", help="comma-separated")
    parser.add_argument("--frames", type=int, default=5, help="frames per path (medians)")
    args = parser.parse_args(argv)
    pt = create_renderer("projected-tetrahedra")
    print("| mesh | cells | fan triangles | gs draw ms | host ms | fan ms | raster ms | covered px (gs, host) |")
    print("|---|---|---|---|---|---|---|---|")
    for name in args.meshes.split(","):
        r = measure(pt, name, args.data_dir, args.frames)
        print(f"| {name} | {r['cells']} | {r['triangles']} | {r['gs draw ms']:.0f} | {r['host ms']:.0f} | "
              f"{r['fan ms']:.0f} | {r['raster ms']:.0f} | {r['covered'][0]}, {r['covered'][1]} |", flush=True)


if __name__ == "__main__":
    main()
