"""What a forcemap checkpoint must contain, and checks that fail with the file and the field named.

A checkpoint is LeRobot's ``config.json`` (draccus, JSON) and ``model.safetensors`` (tensors): nothing
is unpickled. Every tensor's shape follows from fitted fields of the config (LeRobot builds the
policy from ``config.json`` and then loads the tensors into it), so a mismatch between the two files
is caught before loading, by reading the safetensors header only.
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
from huggingface_hub import hf_hub_download

from lerobot_forcemap.jsonfile import read_json_object
from lerobot_policy_forcemap.configuration_forcemap import ForceMapConfig

__all__ = [
    "TENSOR_DTYPE",
    "DUMMY_PARAMETER",
    "expected_tensors",
    "check_safetensors_file",
    "check_skill_values",
    "check_processor_files",
    "PROCESSOR_FILES",
    "fetch_hub_checkpoint",
]

logger = logging.getLogger(__name__)

#: fitted arrays are stored in float64 (bit-exact round trips, no float32 rounding of node positions)
TENSOR_DTYPE = "F64"
#: the one parameter LeRobot's optimiser needs (SPEC §5 / notes §7); its value is never used
DUMMY_PARAMETER = "closed_form_dummy"


def expected_tensors(config: ForceMapConfig) -> dict[str, tuple[tuple[int, ...], str, str]]:
    """``{tensor name: (shape, safetensors dtype, where the shape comes from)}`` for a fitted config."""
    n = int(sum(config.segment_n_nodes))
    g = int(sum(config.segment_n_gripper_nodes))
    s = int(config.n_segments)
    arm = "sum(segment_n_nodes)"
    grip = "sum(segment_n_gripper_nodes)"
    return {
        "nodes": ((n, 3), TENSOR_DTYPE, f"({arm}, 3)"),
        "node_times": ((n,), TENSOR_DTYPE, f"({arm},)"),
        "orientations": ((n, 4), TENSOR_DTYPE, f"({arm}, 4)"),
        "gripper_nodes": ((g, 1), TENSOR_DTYPE, f"({grip}, 1)"),
        "gripper_node_times": ((g,), TENSOR_DTYPE, f"({grip},)"),
        "durations": ((s,), TENSOR_DTYPE, "(n_segments,)"),
        "anchor_poses": ((s, 7), TENSOR_DTYPE, "(n_segments, 7)"),
        "anchor_initial_poses": ((s, 7), TENSOR_DTYPE, "(n_segments, 7)"),
        DUMMY_PARAMETER: ((1,), "F32", "(1,)"),
    }


def check_safetensors_file(path: str | Path, config: ForceMapConfig) -> None:
    """Raise ``ValueError`` (naming ``path`` and the tensor) unless the file matches ``config``.

    Reads the header only: unreadable or truncated files, missing or unexpected tensors, wrong
    shapes (with the config fields the shape derives from) and wrong dtypes are all reported.
    """
    from safetensors import SafetensorError, safe_open

    path = Path(path)
    if not config.is_fitted:
        raise ValueError(
            f"{path.parent / 'config.json'}: n_segments is 0, so this is not a fitted forcemap checkpoint "
            "(fit one with `lerobot-train --policy.type=forcemap --steps=1 ...` or `forcemap fit`)"
        )
    if not path.is_file():
        raise ValueError(
            f"{path}: file not found (a forcemap checkpoint needs model.safetensors next to config.json)"
        )
    try:
        with safe_open(str(path), framework="pt") as f:
            found = {k: (tuple(f.get_slice(k).get_shape()), f.get_slice(k).get_dtype()) for k in f.keys()}  # noqa: SIM118
    except (SafetensorError, OSError, ValueError) as err:
        raise ValueError(f"{path}: not a readable safetensors file ({err})") from err
    want = expected_tensors(config)
    missing = sorted(set(want) - set(found))
    if missing:
        raise ValueError(f"{path}: missing tensor(s) {missing}; a forcemap checkpoint has {sorted(want)}")
    unexpected = sorted(set(found) - set(want))
    if unexpected:
        raise ValueError(
            f"{path}: unexpected tensor(s) {unexpected}; a forcemap checkpoint has {sorted(want)}"
        )
    for name, (shape, dtype, rule) in want.items():
        got_shape, got_dtype = found[name]
        if got_shape != shape:
            raise ValueError(
                f"{path}: tensor {name!r} has shape {got_shape}, but config.json implies {shape} = {rule} "
                f"(n_segments={config.n_segments}, segment_n_nodes={list(config.segment_n_nodes)}, "
                f"segment_n_gripper_nodes={list(config.segment_n_gripper_nodes)}); the two files do not belong together"
            )
        if got_dtype != dtype:
            raise ValueError(f"{path}: tensor {name!r} has dtype {got_dtype}, expected {dtype}")


def check_skill_values(arrays: dict[str, np.ndarray], config: ForceMapConfig, source: str) -> None:
    """Raise ``ValueError`` naming ``source`` and the field for non-finite or inconsistent fitted values."""
    for name, a in arrays.items():
        bad = ~np.isfinite(a)
        if bad.any():
            raise ValueError(
                f"{source}: tensor {name!r} has {int(bad.sum())} non-finite value(s), first at {np.argwhere(bad)[0].tolist()}"
            )
    durations = arrays["durations"]
    if np.any(durations <= 0):
        raise ValueError(f"{source}: tensor 'durations' must be > 0, got {durations.tolist()}")
    offsets = {"node_times": config.segment_n_nodes, "gripper_node_times": config.segment_n_gripper_nodes}
    for name, sizes in offsets.items():
        for s, part in enumerate(np.split(arrays[name], np.cumsum(sizes)[:-1])):
            if np.any(np.diff(part) < 0):
                raise ValueError(f"{source}: tensor {name!r} decreases within segment {s}")
            # node times run from the segment's start (0) to its end (its duration); float32 slack
            slack = 1e-6 * max(1.0, float(durations[s]))
            if part.size and (part[0] < -slack or part[-1] > durations[s] + slack):
                raise ValueError(
                    f"{source}: tensor {name!r} in segment {s} spans [{part[0]:.6g}, {part[-1]:.6g}] s, "
                    f"outside the segment's [0, {durations[s]:.6g}] s (tensor 'durations')"
                )
    for name, quats in (
        ("orientations", arrays["orientations"]),
        ("anchor_poses", arrays["anchor_poses"][:, 3:7]),  # [x y z qw qx qy qz] per segment
        ("anchor_initial_poses", arrays["anchor_initial_poses"][:, 3:7]),
    ):
        norms = np.linalg.norm(quats, axis=1)
        if np.any(np.abs(norms - 1.0) > 1e-6):
            i = int(np.argmax(np.abs(norms - 1.0)))
            raise ValueError(
                f"{source}: tensor {name!r} row {i} is not a unit quaternion (norm {norms[i]:.6g})"
            )


#: LeRobot's pre-/post-processor pipelines saved next to the policy (``make_pre_post_processors`` reads them)
PROCESSOR_FILES = ("policy_preprocessor.json", "policy_postprocessor.json")
#: processor steps whose state file holds dataset statistics keyed '<feature>.<statistic>'
STATS_STEPS = ("normalizer_processor", "unnormalizer_processor")


def check_processor_files(
    folder: str | Path, *, required: bool, warn_missing: bool = True, raw_values: bool = False
) -> None:
    """Raise ``ValueError`` naming the file unless the processor pipelines in ``folder`` are readable.

    LeRobot reports a truncated state file as a bare ``SafetensorError`` and a broken pipeline JSON as a
    JSON error, neither naming the file, and a missing pipeline as a checkpoint "requiring migration".
    LeRobot also imports and calls whatever a step's ``"class"`` names before checking it is a processor
    step, so a pipeline file could run any importable callable: steps must name a registered processor
    (``"registry_name"``) or a ``ProcessorStep`` class of LeRobot or this plugin.
    ``required``: whether the pipelines must be there (``lerobot-eval``/``forcemap eval``/``push`` load
    them; ``ForceMapPolicy.from_pretrained`` alone does not). ``warn_missing``: warn about a missing
    optional pipeline (off where :func:`fetch_hub_checkpoint` already said why it is missing).
    ``raw_values``: the policy acts on raw dataset values (forcemap), so every normaliser step must map
    each feature type to IDENTITY (a learned policy's checkpoint normalises, and is checked without it).
    """
    from safetensors import SafetensorError, safe_open

    folder = Path(folder)
    for name in PROCESSOR_FILES:
        path = folder / name
        if not path.is_file():
            if required:
                raise ValueError(
                    f"{path}: file not found (a checkpoint saved by lerobot-train or forcemap fit has "
                    f"{' and '.join(PROCESSOR_FILES)} next to config.json)"
                )
            if warn_missing:
                # lerobot-eval would call this a checkpoint "requiring migration" without naming the file
                logger.warning("%s: file not found; lerobot-eval needs it to run this policy", path)
            continue
        steps = read_json_object(path).get("steps")
        if not isinstance(steps, list):
            raise ValueError(f"{path}: expected a 'steps' list, got {type(steps).__name__}")
        for i, step in enumerate(steps):
            _check_step_config(_check_step_class(step, f"{path}: steps[{i}]"), step, f"{path}: steps[{i}]")
            norm_map = step.get("config", {}).get("norm_map") or {}
            if raw_values and isinstance(norm_map, dict) and any(m != "IDENTITY" for m in norm_map.values()):
                # the maps act on raw dataset values: a normalising step would feed them other units
                raise ValueError(
                    f"{path}: steps[{i}].config.norm_map must map every feature type to 'IDENTITY' (the "
                    f"forcemap policy is fitted on raw dataset values), got {norm_map}"
                )
            state_file = step.get("state_file")
            if state_file is None:
                continue
            state = folder / str(state_file)
            if Path(str(state_file)).name != str(state_file) or state.suffix != ".safetensors":
                raise ValueError(
                    f"{path}: steps[{i}].state_file {state_file!r} must name a .safetensors file in {folder}"
                )
            if not state.is_file():
                raise ValueError(f"{state}: file not found ({path} steps[{i}] needs it)")
            try:
                with safe_open(str(state), framework="pt") as f:
                    keys = list(f.keys())
                    for key in keys:
                        f.get_slice(key)
            except (SafetensorError, OSError, ValueError) as err:
                raise ValueError(f"{state}: not a readable safetensors file ({err})") from err
            if step.get("registry_name") in STATS_STEPS:
                # LeRobot splits each key at its last '.' into feature and statistic, failing on any other
                # key with an unpacking error that names neither the file nor the key
                bad = [k for k in keys if not all(k.rpartition(".")[::2])]
                if bad:
                    raise ValueError(
                        f"{state}: tensor {bad[0]!r} is not named '<feature>.<statistic>' (e.g. 'action.mean'), "
                        f"as the {step['registry_name']} state of {path} steps[{i}] must be"
                    )


#: modules a pipeline step's ``"class"`` may come from (imported to check the class; nothing else is)
TRUSTED_STEP_MODULES = ("lerobot", "lerobot_policy_forcemap")


def _check_step_class(step: object, where: str) -> type:
    """The processor step class ``step`` names; ``ValueError`` unless LeRobot may safely build it."""
    import importlib

    from lerobot.processor import ProcessorStep, ProcessorStepRegistry

    if not isinstance(step, dict):
        raise ValueError(f"{where}: expected an object, got {type(step).__name__}")
    if "registry_name" in step:
        name = step["registry_name"]
        if not isinstance(name, str) or name not in ProcessorStepRegistry.list():
            raise ValueError(
                f"{where}.registry_name {name!r} is not a registered LeRobot processor step "
                f"(known: {', '.join(sorted(ProcessorStepRegistry.list()))})"
            )
        return ProcessorStepRegistry.get(name)
    path = step.get("class")
    if not isinstance(path, str) or "." not in path:
        raise ValueError(f"{where}: needs 'registry_name' or 'class' (module.ClassName), got {path!r}")
    module_name, class_name = path.rsplit(".", 1)
    if module_name.split(".")[0] not in TRUSTED_STEP_MODULES:
        raise ValueError(
            f"{where}.class {path!r}: only processor steps from {' or '.join(TRUSTED_STEP_MODULES)} are "
            "loaded (LeRobot would import and call it before checking it is a processor step)"
        )
    try:
        cls = getattr(importlib.import_module(module_name), class_name)
    except (ImportError, AttributeError) as err:
        raise ValueError(f"{where}.class {path!r} cannot be imported ({err})") from err
    if not (isinstance(cls, type) and issubclass(cls, ProcessorStep)):
        raise ValueError(f"{where}.class {path!r} is not a LeRobot ProcessorStep")
    return cls


def _check_step_config(cls: type, step: dict, where: str) -> None:
    """``step["config"]`` holds only arguments of ``cls`` (LeRobot calls ``cls(**config)`` and reports an
    unexpected one without naming the file)."""
    import inspect

    config = step.get("config", {})
    if not isinstance(config, dict):
        raise ValueError(f"{where}.config: expected an object, got {type(config).__name__}")
    params = inspect.signature(cls).parameters
    if any(p.kind is inspect.Parameter.VAR_KEYWORD for p in params.values()):
        return
    unknown = sorted(set(config) - set(params))
    if unknown:
        raise ValueError(
            f"{where}.config: unknown key(s) {', '.join(map(repr, unknown))} for {cls.__name__} "
            f"(it takes: {', '.join(params)})"
        )


#: the files of a checkpoint on the Hub, the processor pipelines optional (``from_pretrained`` alone
#: does not need them; their state files are fetched by name from the pipelines)
HUB_REQUIRED_FILES = ("config.json", "model.safetensors")


def fetch_hub_checkpoint(repo_id: str, hub_kwargs: dict) -> Path:
    """Download (or find in the local cache) the checkpoint files of ``repo_id``; returns their folder.

    Loading then runs the same checks as for a local folder. Without this, a Hub checkpoint skipped
    them, and a cache lacking a file (offline) surfaced as huggingface_hub's bare "check your
    connection" error. ``hub_kwargs``: ``hf_hub_download`` arguments (revision, cache_dir, token...).
    """
    from huggingface_hub import is_offline_mode
    from huggingface_hub.errors import EntryNotFoundError, HfHubHTTPError, LocalEntryNotFoundError

    offline = is_offline_mode()

    def fetch(filename: str, *, required: bool) -> Path | None:
        try:
            return Path(hf_hub_download(repo_id=repo_id, filename=filename, **hub_kwargs))
        except LocalEntryNotFoundError as err:
            if not (offline or hub_kwargs.get("local_files_only")):
                raise ValueError(f"{repo_id}: cannot download {filename} ({err})") from err
            what = (
                f"{repo_id}: {filename} is not in the local Hugging Face cache and the Hub is not asked "
                f"(HF_HUB_OFFLINE={offline}, local_files_only="
                f"{bool(hub_kwargs.get('local_files_only'))})"
            )
            if required:
                raise ValueError(
                    f"{what}: download the checkpoint once online, or pass a local folder"
                ) from err
            # maybe the repo has none (the policy loads without it); lerobot-eval will need it
            logger.warning("%s; lerobot-eval needs it to run this policy", what)
            return None
        except EntryNotFoundError as err:
            if not required:
                if filename in PROCESSOR_FILES:  # a missing state file is an error of the checks that follow
                    logger.warning(
                        "%s: the repo has no %s; lerobot-eval needs it to run this policy", repo_id, filename
                    )
                return None
            raise ValueError(
                f"{repo_id}: the repo has no {filename} (a forcemap checkpoint holds "
                f"{', '.join(HUB_REQUIRED_FILES)} and {', '.join(PROCESSOR_FILES)})"
            ) from err
        except HfHubHTTPError as err:  # no such repo or revision, no access
            raise ValueError(f"{repo_id}: cannot read {filename} from the Hub ({err})") from err

    folder = fetch("config.json", required=True).parent
    for name in HUB_REQUIRED_FILES[1:]:
        fetch(name, required=True)
    for name in PROCESSOR_FILES:
        pipeline = fetch(name, required=False)
        steps = read_json_object(pipeline).get("steps") if pipeline else None
        for step in steps if isinstance(steps, list) else ():
            state_file = step.get("state_file") if isinstance(step, dict) else None
            # only plain file names are fetched: check_processor_files reports any other value
            if isinstance(state_file, str) and Path(state_file).name == state_file:
                fetch(state_file, required=False)
    return folder
