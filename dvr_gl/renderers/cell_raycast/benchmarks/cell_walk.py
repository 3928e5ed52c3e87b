"""A measurement for issue 16's open speed target: ray casting from cell to cell through a mesh in
one fragment shader (Weiler et al. 2003's hardware-assisted ray casting, HARC), against
``projected-tetrahedra``'s draw.  The prototype of the ``cell-raycast`` renderer
(``dvr_gl/renderers/cell_raycast``: its lists, with the boundary's faces grown by a twentieth of a
pixel, fixed the crease fault below); kept for the record of what was measured on the way.

    python dvr_gl/renderers/cell_raycast/benchmarks/cell_walk.py [--data-dir ../shared/data]
        [--meshes bluntfin,comb,post] [--size 512] [--passes 4 | --lists]

Each pass, a pixel's ray enters the mesh where the boundary's entering faces beyond its last exit
are nearest (the boundary drawn with the depth test, each face carrying its cell and its outward
normal), then walks: clip against the cell's four planes (the renderer's textures), integrate the
exact transfer function along the piece (the renderer's ``transfer_segment.glsl``), composite front
to back, step into the neighbour across the exit face, until it leaves the mesh.  ``--passes``
walks follow a ray out of the mesh and back in (through a concavity, across a block interface
with duplicated points).  No footprints and no visibility order.  One run, 512x512, first bench
view (30/20), 4 passes:

| mesh | walk ms | projected-tetrahedra draw ms (centroid order, no order time) | RMS walk vs PT |
|---|---:|---:|---:|
| bluntfin | 358 | 870 | 1.1e-7 |
| comb | 486 | 1281 | 1.4e-7 |
| post | 363 | 1044 | 1.6e-3 |
| jaw | 386 | 1068 | 2.1e-3 |
| notch | 116 | 92 | 8.9e-4 |

Where the post, the jaw and the notched part are off (2026-11-24, same size and view; "pixels off":
more than 1e-2 in some channel): the jaw is 322 pixels off with 4 passes, 1 with 8 (RMS 2.1e-3 to
2.9e-4), and the notched part 1335, 194 and 62 pixels with 4, 8 and 16 passes (8.9e-4, 3.9e-4,
2.9e-4): most of the error is rays that leave and re-enter the mesh more often than the passes
allow (the jaw's teeth, the notch's gaps), each re-entry costing a full-screen pass.

``--lists`` removes the passes: the entering boundary faces are drawn once into per-pixel linked
lists (an A-buffer: a shader storage buffer of nodes, an image of list heads, an atomic counter;
16 nodes a pixel reserved, overflow detected), and one walk reads its pixel's list, sorts it by
depth (insertion sort, at most 64 entries) and continues at the next entry beyond each exit.  No
visibility order and no passes; one run, 512x512, 2026-11-24:

| mesh | walk ms (lists) | projected-tetrahedra draw ms | RMS walk vs PT | pixels off by > 1e-2 |
|---|---:|---:|---:|---:|
| bluntfin | 258 | 725 | 8.0e-8 | 0 |
| comb | 251 | 878 | 1.4e-7 | 0 |
| post | 232 | 869 | 1.2e-3 | 1 |
| jaw | 208 | 953 | 2.9e-4 | 1 |
| notch | 40 | 67 | 4.0e-5 | 3 |

3.4-4.6x faster than projected tetrahedra's draw alone (which also needs its order), and below
VTK's whole projected-tetrahedra frame on the blunt fin and the combustion chamber (335-380 ms in
``dvr bench cells``).  Two faults traced on the pixels left over (each pixel compared with the
float64 mesh reference and a float32 and float64 emulation of the walk, which both follow the
reference's pieces):

* a walk caught in a cycle through cells the ray only touches (21,832 steps on one notch pixel)
  ran into llvmpipe's loop cap, which counts a SIMD group's iterations, and cut its neighbours'
  walks short (a row of 4 notch pixels with half their opacity): a walk now gives up after 32 steps
  in a row that do not advance (``MAX_STALLS``; notch 11 to 3 pixels);
* the post's pixel: the ray grazes the outer boundary at a crease, leaving one face and re-entering
  the next 0.0015 further (both faces edge on, n.d = 2e-4 and -1e-4); the entering face's fragment
  is missing from the list (a sliver in screen space, or the sign of n.d in float32), so the walk
  ends there.  Tried: drawing the entering faces' edges as lines too (entries whose cell the ray
  misses dropped): far worse (post 37 pixels off, blunt fin 105, twice the time), as an edge's line
  also lists faces the ray does not enter by.  Next: grow the entering faces' footprints by a
  fraction of a pixel as projected tetrahedra does, keeping an entry only where the ray crosses
  the face itself (its barycentric coordinates, not the cell).

Tried and dropped:
never leaving a cell through the face it was entered by (a ray that only grazes a cell may have no
other exit in float32: NaN on the blunt fin and the post).

The same walk emulated in float64 on the post (every seventh ray at 128x128) follows the exact
pieces and needs at most 2 passes, so the post's error lies in the float32 GL path: the entry found
at a block interface, or a step into the wrong neighbour where a ray passes near an edge (one pixel
off by 0.5 makes RMS 1e-3 at 512x512; at 256x256 the post matches to 1.8e-7).  The interface
tolerance (``u_touching``, 1e-5 of the diagonal) is right between 1e-6 and 1e-4 (1e-3 takes faces
behind the exit, 1e-7 misses the coincident ones: 5.8e-3 and 2.9e-2).  VTK's projected tetrahedra
took 335-763 ms a frame on the large meshes in ``dvr bench cells``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import moderngl
import numpy as np

from dvr_gl.bench import picks
from dvr_gl.bench.datasets import MESHES
from dvr_gl.bench.datasets import mesh_scene_keys as scene_keys
from dvr_gl.fields.mesh_rays import face_neighbours
from dvr_gl.gl.context import make_current
from dvr_gl.gl.shaders import LIBRARY
from dvr_gl.renderers import create_renderer
from dvr_gl.renderers.mesh import SHADERS as MESH_SHADERS
from dvr_gl.renderers.mesh.textures import ROW
from dvr_gl.renderers.mesh.textures import rows as _rows
from dvr_gl.scene.resolve import load_scene

ENTRY_VS = """#version 430
layout(location = 0) in vec3 in_position;
layout(location = 1) in uint in_cell;
layout(location = 2) in vec3 in_normal;
uniform mat4 u_view_projection;
flat out uint v_cell;
flat out vec3 v_normal;
out vec3 v_position;
void main() {
    v_cell = in_cell;
    v_normal = in_normal;
    v_position = in_position;
    gl_Position = u_view_projection * vec4(in_position, 1.0);
}
"""
ENTRY_FS_MAIN = """
flat in uint v_cell;
flat in vec3 v_normal;
in vec3 v_position;
uniform sampler2D u_exit;   // where each pixel's ray last left the mesh (-1: nowhere yet)
uniform float u_touching;   // crossings this close meet
layout(location = 0) out uint cell;
void main() {
    vec3 o, d;
    camera_ray(o, d);
    if (dot(v_normal, d) >= 0.0) discard;  // a face the ray leaves by
    float t = dot(v_position - o, d);
    float last = texelFetch(u_exit, ivec2(gl_FragCoord.xy), 0).r;
    if (t <= last - u_touching) discard;   // passed already
    cell = v_cell + 1u;
}
"""
LIST_FS_MAIN = """
flat in uint v_cell;
flat in vec3 v_normal;
in vec3 v_position;
layout(std430, binding = 0) buffer Nodes { uvec4 nodes[]; };  // (cell, t bits, next node + 1, 0)
layout(std430, binding = 1) buffer Count { uint node_count; };
layout(r32ui, binding = 0) uniform coherent uimage2D u_heads;  // first node + 1 per pixel, 0: none
uniform uint u_capacity;
layout(location = 0) out vec4 unused;
void main() {
    vec3 o, d;
    camera_ray(o, d);
    if (dot(v_normal, d) >= 0.0) discard;  // a face the ray leaves by
    uint i = atomicAdd(node_count, 1u);
    if (i >= u_capacity) discard;  // counted: the caller sees the overflow
    uint next = imageAtomicExchange(u_heads, ivec2(gl_FragCoord.xy), i + 1u);
    nodes[i] = uvec4(v_cell, floatBitsToUint(dot(v_position - o, d)), next, 0u);
    unused = vec4(0.0);
}
"""
WALK_STEPS = """
uniform isampler2D u_neighbours;
const int MAX_STALLS = 32;
// From `cell`, entered at t_prev: clip the ray against the cell's planes, integrate the transfer
// function along the piece inside and composite it front to back into acc, step into the neighbour
// across the exit face; until the ray leaves the mesh (t_prev: where) or is opaque.
void walk(uint cell, vec3 o, vec3 d, inout float t_prev, inout vec4 acc) {
    int stalls = 0;  // steps in a row that did not advance along the ray
    for (int i = 0; i < 65536; ++i) {
        vec4 p0 = cell_texel(cell, 0u), p1 = cell_texel(cell, 1u), p2 = cell_texel(cell, 2u), p3 = cell_texel(cell, 3u);
        vec4 side = cell_texel(cell, 4u), lin = cell_texel(cell, 5u);
        vec4 nd = vec4(dot(p0.xyz, d), dot(p1.xyz, d), dot(p2.xyz, d), dot(p3.xyz, d)) * side;
        vec4 no = (vec4(dot(p0.xyz, o), dot(p1.xyz, o), dot(p2.xyz, o), dot(p3.xyz, o))
                   - vec4(p0.w, p1.w, p2.w, p3.w)) * side;
        vec4 t = -no / nd;
        vec4 t_in = mix(vec4(-3e38), t, greaterThan(nd, vec4(0.0)));
        vec4 t_out = mix(vec4(3e38), t, lessThan(nd, vec4(0.0)));
        float a = max(max(max(t_in.x, t_in.y), max(t_in.z, t_in.w)), t_prev);
        float b = min(min(t_out.x, t_out.y), min(t_out.z, t_out.w));
        int k = b == t_out.x ? 0 : b == t_out.y ? 1 : b == t_out.z ? 2 : 3;
        if (b > a) {
            float sf = dot(lin.xyz, o + a * d) + lin.w, sb = dot(lin.xyz, o + b * d) + lin.w;
            acc += (1.0 - acc.a) * transfer_segment(sf, sb, b - a);
        }
        // Steps through cells the ray only touches (an edge, a vertex) do not advance; rounding can
        // send such steps round in a cycle, which llvmpipe's loop cap (65535 iterations per SIMD
        // group) then ends for the neighbouring pixels too: give the ray up (to the next entry).
        stalls = b > t_prev ? 0 : stalls + 1;
        if (stalls > MAX_STALLS) break;
        t_prev = max(b, t_prev);
        int next = texelFetch(u_neighbours, texel_of(cell), 0)[k];
        if (next < 0 || acc.a > 0.9999) break;
        cell = uint(next);
    }
}
"""
WALK_VS = """#version 430
void main() { gl_Position = vec4(gl_VertexID == 1 ? 3.0 : -1.0, gl_VertexID == 2 ? 3.0 : -1.0, 0.0, 1.0); }
"""
WALK_MAIN = """
uniform usampler2D u_entry;
uniform sampler2D u_before;  // the colour so far (front to back)
uniform sampler2D u_exit;    // where the ray last left the mesh
layout(location = 0) out vec4 frag;
layout(location = 1) out vec4 exit_t;
void main() {
    uint c = texelFetch(u_entry, ivec2(gl_FragCoord.xy), 0).r;
    vec4 acc = texelFetch(u_before, ivec2(gl_FragCoord.xy), 0);
    float t_prev = texelFetch(u_exit, ivec2(gl_FragCoord.xy), 0).r;
    if (c == 0u) { frag = acc; exit_t = vec4(3e38); return; }
    vec3 o, d;
    camera_ray(o, d);
    walk(c - 1u, o, d, t_prev, acc);
    frag = acc;
    exit_t = vec4(acc.a > 0.9999 ? 3e38 : t_prev);
}
"""


WALK_LISTS_MAIN = """
layout(std430, binding = 0) buffer Nodes { uvec4 nodes[]; };
layout(r32ui, binding = 0) uniform readonly uimage2D u_heads;
uniform float u_touching;
layout(location = 0) out vec4 frag;
const int MAX_ENTRIES = 64;
void main() {
    float entry_t[MAX_ENTRIES];
    uint entry_cell[MAX_ENTRIES];
    int count = 0;
    uint node = imageLoad(u_heads, ivec2(gl_FragCoord.xy)).r;
    while (node != 0u && count < MAX_ENTRIES) {  // insertion sort by t as the list is read
        uvec4 n = nodes[node - 1u];
        float t = uintBitsToFloat(n.y);
        int j = count++;
        while (j > 0 && entry_t[j - 1] > t) { entry_t[j] = entry_t[j - 1]; entry_cell[j] = entry_cell[j - 1]; --j; }
        entry_t[j] = t;
        entry_cell[j] = n.x;
        node = n.z;
    }
    vec4 acc = vec4(0.0);
    vec3 o, d;
    camera_ray(o, d);
    float t_prev = -3e38;
    for (int e = 0; e < count && acc.a <= 0.9999; ++e) {
        if (entry_t[e] <= t_prev - u_touching) continue;  // passed already
        walk(entry_cell[e], o, d, t_prev, acc);
    }
    frag = acc;
}
"""


def walk_source(tf, main=None) -> str:
    defines = [f"#define TF_COUNT {len(tf.points)}", f"#define TF_POW2 {1 << len(tf.points).bit_length()}"]
    if tf.opacity_model == "alpha":
        defines.append("#define ALPHA_MODEL")
    parts = [(root / p).read_text() for root, p in
             ((LIBRARY, "common/camera_ray.glsl"), (MESH_SHADERS, "mesh_fetch.glsl"),
              (MESH_SHADERS, "transfer_segment.glsl"))]
    return "\n".join(["#version 430", *defines, *parts, WALK_STEPS, main or WALK_MAIN])


def entry_source(main=ENTRY_FS_MAIN) -> str:
    return "\n".join(["#version 430", (LIBRARY / "common/camera_ray.glsl").read_text(), main])


def measure(name: str, data_dir: Path, size: int, passes: int, lists: bool = False) -> dict:
    source, array = MESHES[name]
    path = data_dir / source
    mesh = load_scene(None, {"volume.path": str(path), **({"volume.array": array} if array else {})}).field
    scene = load_scene(None, {**scene_keys(path, array, mesh), "camera.azimuth": 30.0, "camera.elevation": 20.0,
                              "image.width": size, "image.height": size})
    pt = create_renderer(picks.baseline("mesh"))  # projected tetrahedra, the default mesh renderer
    exact = pt.render(scene).astype(np.float64)
    ctx = pt.ctx
    make_current(ctx)
    kept = pt._cache["mesh"][1]  # the rendered mesh's textures and visibility order
    textures, orders = kept.textures, kept.extra
    texels = _rows(face_neighbours(mesh.tets), np.int32)
    nb = ctx.texture((ROW, texels.shape[0]), 4, texels.tobytes(), dtype="i4")
    nb.filter = (moderngl.NEAREST, moderngl.NEAREST)
    adj = orders.adjacency
    corners = (adj.boundary_corners - textures.centre).astype(np.float32).reshape(-1, 3)
    cells = np.repeat(adj.boundary_cell.astype(np.uint32), 3)
    normals = np.repeat(adj.boundary_normal.astype(np.float32), 3, axis=0)
    vbo = ctx.buffer(np.concatenate([corners.view(np.uint32), cells[:, None], normals.view(np.uint32)],
                                    axis=1).tobytes())
    entry = ctx.program(vertex_shader=ENTRY_VS, fragment_shader=entry_source())
    walk = ctx.program(vertex_shader=WALK_VS, fragment_shader=walk_source(scene.transfer_function))
    for program in (entry, walk):
        pt._uniforms(program, scene, textures)
    lo, hi = (np.asarray(b, float) for b in mesh.bounds)
    entry["u_touching"].value = 1e-5 * float(np.linalg.norm(hi - lo))
    entry_cell = ctx.texture((size, size), 1, dtype="u4")
    entry_fbo = ctx.framebuffer([entry_cell], ctx.depth_texture((size, size)))
    # ping-pong: (colour so far, last exit) read, the next written
    targets = [(ctx.texture((size, size), 4, dtype="f4"), ctx.texture((size, size), 1, dtype="f4")) for _ in range(2)]
    fbos = [ctx.framebuffer(list(t)) for t in targets]
    for tex in [entry_cell, *[t for pair in targets for t in pair]]:
        tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
    entry_vao = ctx.vertex_array(entry, [(vbo, "3f 1u 3f", "in_position", "in_cell", "in_normal")])
    walk_vao = ctx.vertex_array(walk, [])

    def bind(program, named):
        for unit, (uniform, tex) in enumerate(named):
            tex.use(location=unit)
            if uniform in program:
                program[uniform].value = unit

    def passes_frame():
        start = time.perf_counter()
        fbos[0].use()
        fbos[0].viewport = (0, 0, size, size)
        fbos[0].clear(0.0, 0.0, 0.0, 0.0)
        targets[0][1].write(np.full((size, size), -3e38, np.float32).tobytes())  # nothing passed yet
        ctx.disable(moderngl.BLEND | moderngl.CULL_FACE)
        for p in range(passes):
            read, write = targets[p % 2], fbos[(p + 1) % 2]
            entry_fbo.use()
            entry_fbo.viewport = (0, 0, size, size)
            entry_fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
            ctx.enable(moderngl.DEPTH_TEST)
            ctx.depth_func = "<"
            bind(entry, [("u_exit", read[1])])
            entry_vao.render(moderngl.TRIANGLES)
            ctx.disable(moderngl.DEPTH_TEST)
            bind(walk, [*textures.textures, ("u_entry", entry_cell), ("u_neighbours", nb), ("u_before", read[0]),
                        ("u_exit", read[1])])
            write.use()
            write.viewport = (0, 0, size, size)
            walk_vao.render(moderngl.TRIANGLES, vertices=3)
        out = targets[passes % 2][0]
        image = np.frombuffer(out.read(), np.float32).reshape(size, size, 4)[::-1]
        return image, time.perf_counter() - start

    if lists:  # one walk over per-pixel lists of entering faces
        capacity = 16 * size * size
        nodes = ctx.buffer(reserve=16 * capacity)
        counter = ctx.buffer(reserve=4)
        heads = ctx.texture((size, size), 1, dtype="u4")
        list_prog = ctx.program(vertex_shader=ENTRY_VS, fragment_shader=entry_source(LIST_FS_MAIN))
        walk_lists = ctx.program(vertex_shader=WALK_VS,
                                 fragment_shader=walk_source(scene.transfer_function, WALK_LISTS_MAIN))
        for program in (list_prog, walk_lists):
            pt._uniforms(program, scene, textures)
        list_prog["u_capacity"].value = capacity
        walk_lists["u_touching"].value = entry["u_touching"].value
        list_vao = ctx.vertex_array(list_prog, [(vbo, "3f 1u 3f", "in_position", "in_cell", "in_normal")])
        walk_lists_vao = ctx.vertex_array(walk_lists, [])
        dummy = ctx.framebuffer([ctx.texture((size, size), 1, dtype="f1")])
        out_tex = ctx.texture((size, size), 4, dtype="f4")
        out_fbo = ctx.framebuffer([out_tex])
        zeros = np.zeros((size, size), np.uint32).tobytes()

        def lists_frame():
            start = time.perf_counter()
            heads.write(zeros)
            counter.write(np.zeros(1, np.uint32).tobytes())
            nodes.bind_to_storage_buffer(0)
            counter.bind_to_storage_buffer(1)
            heads.bind_to_image(0, read=True, write=True)
            ctx.disable(moderngl.BLEND | moderngl.CULL_FACE | moderngl.DEPTH_TEST)
            dummy.use()
            dummy.viewport = (0, 0, size, size)
            list_vao.render(moderngl.TRIANGLES)
            ctx.memory_barrier()
            bind(walk_lists, [*textures.textures, ("u_neighbours", nb)])
            heads.bind_to_image(0, read=True, write=False)
            out_fbo.use()
            out_fbo.viewport = (0, 0, size, size)
            walk_lists_vao.render(moderngl.TRIANGLES, vertices=3)
            image = np.frombuffer(out_tex.read(), np.float32).reshape(size, size, 4)[::-1]
            used = int(np.frombuffer(counter.read(), np.uint32)[0])
            if used > capacity:
                raise RuntimeError(f"{name}: {used} entering faces, more than the {capacity} the lists hold")
            return image, time.perf_counter() - start

    frame = lists_frame if lists else passes_frame
    image, _ = frame()
    walk_ms = 1e3 * min(frame()[1] for _ in range(3))
    draws = []
    for _ in range(3):
        pt.render(scene.with_renderer(cell_order="centroid"))
        draws.append(pt.stats["draw_seconds"])
    pt.close()
    off = np.abs(image - exact).max(axis=2)
    return {"mesh": name, "walk_ms": walk_ms, "pt_ms": 1e3 * min(draws),
            "rms": float(np.sqrt(np.mean((image - exact) ** 2))), "off": int((off > 1e-2).sum()),
            "worst": np.unravel_index(np.argmax(off), off.shape)}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data-dir", type=Path, default=Path(__file__).resolve().parents[5] / "shared" / "data")
    parser.add_argument("--meshes", default="bluntfin,comb,post")
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--passes", type=int, default=4, help="walks: the first entry and re-entries")
    parser.add_argument("--lists", action="store_true",
                        help="one walk over per-pixel lists of entering boundary faces instead of passes")
    args = parser.parse_args(argv)
    print("| mesh | walk ms | projected-tetrahedra draw ms | RMS walk vs PT | pixels off by > 1e-2 | worst pixel |\n"
          "|---|---:|---:|---:|---:|---|")
    for name in args.meshes.split(","):
        if not (args.data_dir / MESHES[name][0]).exists():
            print(f"{name}: not found under {args.data_dir} (--data-dir)", file=sys.stderr)
            continue
        row = measure(name, args.data_dir, args.size, args.passes, args.lists)
        print(f"| {row['mesh']} | {row['walk_ms']:.0f} | {row['pt_ms']:.0f} | {row['rms']:.1e} | {row['off']} | "
              f"{tuple(int(i) for i in row['worst'])} |", flush=True)


if __name__ == "__main__":
    main()
