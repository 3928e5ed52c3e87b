"""The fields of ``dvr render`` and ``dvr view`` (docs/cli.md, "Several fields and time"): the data files of the
command line, each a field of one scene, composited per sample (docs/several-fields.md).

Files given where the scene file goes are scalar fields (a file with channels: each channel a field);
``--labels FILE`` adds a label map and ``--rgb FILE`` a colour volume, in command-line order.  One scalar file is
the scene's ``[volume]``, as it always was (the same image, bit for bit); several files, or a role, make one
``[[volume]]`` table per file, in that order.  The volume file options (``--format``, ``--spacing``,
``--channel``, ...) apply to every file, ``--time K`` to every file with time steps.  ``--transfer-function``
given once is the first field's; given once per file, the k-th is the k-th file's; one file with C channels and
C transfer functions: one table per channel, the k-th function channel k's.
"""

from __future__ import annotations

import argparse
import copy
import os
from dataclasses import dataclass, field

from dvr_gl.errors import DvrError
from dvr_gl.scene.resolve import effective_renderer_dict, is_volume_path, load_scene
from dvr_gl.transfer_function import is_transfer_function_file

#: the flags that add a field in a role other than scalar (the files where the scene goes are scalar)
ROLE_FLAGS = {"--labels": "label", "--rgb": "rgb"}


class FieldFiles(argparse.Action):
    """Records each data file with its role in ``args.fields``, in command-line order; the files where the scene
    file goes get role None (scalar fields, or the scene file: :func:`sort_files` tells them apart)."""

    def __call__(self, parser, namespace, values, option_string=None):
        files = values if isinstance(values, list) else [values]
        role = ROLE_FLAGS.get(option_string)
        namespace.fields = [*(getattr(namespace, "fields", None) or []), *((str(f), role) for f in files)]
        if option_string is None:
            namespace.scene = None  # set by sort_files


def add_files(p, files_help: str):
    """The files where the scene goes (``SCENE_OR_VOLUME ...``)."""
    p.add_argument("scene", nargs="*", action=FieldFiles, metavar="SCENE_OR_VOLUME", help=files_help)
    p.set_defaults(fields=[], field_files=[])


def add_role_flags(p):
    """The group of the flags of several fields and time, with those that add a field in a role."""
    f = p.add_argument_group("several fields and time (docs/cli.md)")
    f.add_argument("--labels", action=FieldFiles, dest="fields", default=[], metavar="FILE",
                   help="a label map as a further field (colour and opacity per label from its colour table; "
                        "repeatable)")
    f.add_argument("--rgb", action=FieldFiles, dest="fields", default=[], metavar="FILE",
                   help="a colour volume as a further field (colour from the data, opacity from its luminance or "
                        "alpha; repeatable)")
    return f


def sort_files(args):
    """Tell the scene file from the data files: ``args.scene`` (a scene file or None), ``args.volume`` (the one
    scalar file, read as ``--volume``, the single-field path), ``args.field_files`` ([(path, role), ...] when
    there are several fields or a role: one ``[[volume]]`` table each)."""
    given = list(getattr(args, "fields", None) or [])
    scenes = [p for p, role in given if role is None and not is_volume_path(p)]
    data = [(p, role or "scalar") for p, role in given if not (role is None and p in scenes)]
    args.field_files = []
    if len(scenes) > 1:
        raise DvrError(f"{scenes[1]}: give one scene file (its [[volume]] tables name every field)")
    if scenes:
        args.scene = scenes[0]
        if data:
            raise DvrError(f"{data[0][0]}: a scene file names its fields in [[volume]] tables; give {scenes[0]} "
                           f"alone, or the volume files without it")
        return
    args.scene = None
    positional = [p for p, role in given if role is None]
    if positional and (args.volume or args.demo):
        raise DvrError(f"{positional[0]} is a volume file; give it once, without --volume or --demo")
    if args.volume and data:
        data.insert(0, (args.volume, "scalar"))
        args.volume = None
    if data and args.demo:
        raise DvrError(f"{data[0][0]}: give --demo or volume files, not both")
    if len(data) == 1 and data[0][1] == "scalar":
        args.volume = data[0][0]
    else:
        args.field_files = data


def transfer_function_table(value: str, role: str = "scalar") -> dict:
    """A ``--transfer-function`` value as a transfer-function table: a file (made absolute: relative to where dvr
    runs; a label map's is always a colour table file) or a preset's name."""
    if role == "label" or is_transfer_function_file(value) or os.path.isfile(os.path.expanduser(value)):
        return {"file": os.path.abspath(os.path.expanduser(value))}
    return {"preset": value}


@dataclass
class Source:
    """What the command line's scene is made of, before it is loaded: the scene file (or None), the overrides
    (dotted keys), the base dict (the demo's, or the ``[[volume]]`` tables of several files) and, for a time
    animation, the tables that walk their steps (None: the overrides' ``volume.time``)."""

    path: str | None
    overrides: dict
    base: dict | None = None
    timed: list[int] = field(default_factory=list)  # set by timed_files

    def load(self, time: int | None = None, renderer=None):
        """The scene, at step ``time`` of the timed files if given; with the settings of ``renderer`` (the first
        step's, resolved: a tolerance's chosen sample distance), so that a step is read without resolving them
        again (the ray caster's tolerance renders a check)."""
        overrides, base = self.overrides, self.base
        if renderer is not None:
            pinned = {f"renderer.{k}": v for k, v in effective_renderer_dict(renderer).items()}
            overrides = {**{k: v for k, v in overrides.items() if not k.startswith("renderer.")}, **pinned}
        if time is not None and self.is_tables:
            base = copy.deepcopy(base)
            for i in self.timed:
                base["volume"][i]["time"] = time
        elif time is not None:
            overrides = {**overrides, "volume.time": time}
        return load_scene(self.path, overrides, base)

    @property
    def is_tables(self) -> bool:
        return self.base is not None and isinstance(self.base.get("volume"), list)

    def files(self) -> list[tuple[str, dict]]:
        """The data files whose steps a time animation walks: (path, reader options) of each table, or of the
        scene's one volume (found once the scene is loaded: :func:`timed_files`)."""
        if not self.is_tables:
            return []
        keys = ("format", "array", "level", "fourth_axis")
        return [(t["path"], {k: t[k] for k in keys if t.get(k) is not None}) for t in self.base["volume"]]


def source_of(args, overrides: dict, transfer_functions: list[str]) -> Source:
    """The scene the command line asks for (:class:`Source`); ``transfer_functions``: every
    ``--transfer-function`` given, the first already in ``overrides``."""
    from dvr_gl.phantoms import demo_scene

    files, channels = args.field_files, []
    if not files and args.volume and len(transfer_functions) > 1 and "volume.channel" not in overrides:
        count = channels_of(args.volume, overrides)  # one file's channels, a transfer function each
        if count == len(transfer_functions):
            files, channels = [(args.volume, "scalar")] * count, list(range(count))
    if len(transfer_functions) > max(1, len(files)):
        raise DvrError(f"--transfer-function was given {len(transfer_functions)} times for "
                       f"{max(1, len(files))} file{'s' * (len(files) > 1)}: give one per volume file, in their "
                       f"order, or one per channel of a file with channels (a scene file's [[volume]] tables each "
                       f"take their own)")
    if not files:
        base = demo_scene(args.demo, demo_renderer(overrides), overrides) if args.demo and not args.scene else None
        return Source(args.scene, overrides, base)
    volume_keys = {k.removeprefix("volume."): v for k, v in overrides.items() if k.startswith("volume.")}
    time = volume_keys.pop("time", None)
    tables = [{**copy.deepcopy(volume_keys), "path": os.path.abspath(os.path.expanduser(path)), "role": role}
              for path, role in files]
    for table, k in zip(tables, channels):
        table["channel"] = k
    for table, tf in zip(tables, transfer_functions):  # each in its table (a label map's: its colour table)
        table["transfer_function"] = transfer_function_table(tf, table["role"])
    # the first's, now in its table (a --set of these keys without --transfer-function stays the first's)
    given = ("transfer_function.preset", "transfer_function.file") if transfer_functions else ()
    rest = {k: v for k, v in overrides.items() if not k.startswith("volume.") and k not in given}
    source = Source(None, rest, {"volume": tables})
    if time is not None:  # the files with time steps (a file without them beside a series stays as it is)
        timed = [i for i, (path, options) in enumerate(source.files()) if steps_of(path, options)[0] > 1]
        if not timed:
            raise DvrError(f"--time {time}: none of the files has time steps (dvr info FILE lists them)")
        for i in timed:
            tables[i]["time"] = time
    return source


def demo_renderer(overrides: dict):
    """The declaration (:class:`~dvr_gl.scene.plugin.RendererPlugin`) of the renderer that draws the demo: the
    overrides' ``renderer.name``, else the default renderer of a grid (the demo keeps to what it declares)."""
    from dvr_gl.renderers import registry

    name = overrides.get("renderer.name")
    return registry.plugin(name) if name in registry.names() else registry.plugin(registry.default_for("grid"))


def channels_of(path: str, overrides: dict) -> int:
    """The channels of a data file (0: none), read from its header with the reader options the overrides give."""
    from dvr_gl.io import file_axes

    keys = ("format", "array", "level", "fourth_axis")
    options = {k: overrides[f"volume.{k}"] for k in keys if overrides.get(f"volume.{k}") is not None}
    return file_axes(path, **options).channels


def steps_of(path: str, options: dict | None = None) -> tuple[int, float | None]:
    """(the time steps of a data file, seconds between them or None): 1 for a file without time."""
    from dvr_gl.io import time_steps

    return time_steps(path, **(options or {}))


def timed_files(source: Source, scene, required: bool = True) -> tuple[int, float | None] | None:
    """The number of time steps the scene's files walk together and the seconds between them (or None), with
    ``source.timed`` set to the tables that walk them: every file with more than one step; they must have the
    same number.  A scene file or one volume: the first table's file (its ``volume.time`` is what the
    overrides set).  None where no file has time steps, unless ``required`` (then one line)."""
    if source.is_tables:
        files = source.files()
    else:
        first = scene.sources[0] if scene.sources else scene.volume_source
        if not first.path:
            if not required:
                return None
            raise DvrError("--animate time: the scene's data is not a file with time steps (a demo phantom); "
                           "give a volume file with time steps")
        keys = ("format", "array", "level", "fourth_axis")
        files = [(first.path, {k: getattr(first, k) for k in keys if getattr(first, k, None) is not None})]
    counted = [(i, *steps_of(path, options)) for i, (path, options) in enumerate(files)]
    timed = [(i, n, dt) for i, n, dt in counted if n > 1]
    if not timed:
        if not required:
            return None
        which = f"{os.path.basename(files[0][0])} has" if len(files) == 1 else "none of the files has more than"
        raise DvrError(f"--animate time: {which} one time step; dvr info FILE lists a file's steps")
    lengths = {n for _, n, _ in timed}
    if len(lengths) > 1:
        named = ", ".join(f"{os.path.basename(files[i][0])}: {n}" for i, n, _ in timed)
        raise DvrError(f"time steps: the files have different numbers of them ({named}); give files of one "
                       f"length")
    source.timed = [i for i, _, _ in timed]
    return lengths.pop(), timed[0][2]
