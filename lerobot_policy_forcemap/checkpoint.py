"""What a forcemap checkpoint holds, checked before LeRobot builds and loads it.

A checkpoint is LeRobot's ``config.json`` (JSON, parsed by draccus), ``model.safetensors`` (tensors)
and the processor pipelines ``policy_preprocessor.json`` / ``policy_postprocessor.json``: nothing is
unpickled. Every tensor's shape follows from fitted fields of the config (LeRobot builds the policy
from ``config.json``, then loads the tensors into it). Checked here, naming the file and the field,
is what LeRobot would load without a word: tensors that do not fit the config or hold impossible
values, a config missing a fit setting (today's default would stand in for it), a processor step that
normalises (the maps work on raw values) or names an arbitrary callable (LeRobot imports and calls a
step's ``"class"`` before it checks that it is a processor step).
"""

from __future__ import annotations

import contextlib
import importlib
import logging
from pathlib import Path

from huggingface_hub import hf_hub_download

from lerobot_forcemap._validation import fail
from lerobot_forcemap.jsonfile import read_json_object
from lerobot_policy_forcemap.configuration_forcemap import (
    FITTED_FIELDS,
    OPTIONAL_FITTED_FIELDS,
    ForceMapConfig,
)

__all__ = [
    "DUMMY_PARAMETER",
    "SKILL_TENSORS",
    "PROCESSOR_FILES",
    "expected_tensors",
    "read_config_json",
    "check_safetensors_file",
    "check_processor_files",
    "fetch_hub_checkpoint",
    "profile_shapes",
    "PROFILE_TENSORS",
]

logger = logging.getLogger(__name__)

#: the fitted arrays, stored in float64 (bit-exact round trips)
SKILL_TENSORS = (
    "nodes",
    "node_times",
    "orientations",
    "gripper_nodes",
    "gripper_node_times",
    "durations",
    "anchor_poses",
    "anchor_initial_poses",
)
#: the force feedback's arrays (float64; present when the fit found contact, ``n_force_profile`` > 0)
PROFILE_TENSORS = ("force_profile", "force_normal", "force_depth")
#: the one parameter LeRobot's optimiser needs; its value is never used
DUMMY_PARAMETER = "closed_form_dummy"
#: LeRobot's pre-/post-processor pipelines saved next to the policy (``make_pre_post_processors`` reads them)
PROCESSOR_FILES = ("policy_preprocessor.json", "policy_postprocessor.json")
#: modules a pipeline step's ``"class"`` may come from (imported to check the class; nothing else is)
TRUSTED_STEP_MODULES = ("lerobot", "lerobot_policy_forcemap")


def expected_tensors(config: ForceMapConfig) -> dict[str, tuple[tuple[int, ...], str]]:
    """``{tensor name: (shape, safetensors dtype)}`` of a checkpoint fitted with ``config``'s sizes."""
    n, g, s = sum(config.segment_n_nodes), sum(config.segment_n_gripper_nodes), config.n_segments
    shapes = {
        "nodes": (n, 3),
        "node_times": (n,),
        "orientations": (n, 4),
        "gripper_nodes": (g, 1),
        "gripper_node_times": (g,),
        "durations": (s,),
        "anchor_poses": (s, 7),
        "anchor_initial_poses": (s, 7),
    }
    if config.n_force_profile:
        shapes.update(profile_shapes(config))
    return {**{name: (shape, "F64") for name, shape in shapes.items()}, DUMMY_PARAMETER: ((1,), "F32")}


def profile_shapes(config: ForceMapConfig) -> dict[str, tuple[int, ...]]:
    """The feedback's tensors: the expected force along the contact normal per demonstration frame
    (N), the normal (unit, base frame) and per frame the demonstrated force along the normal (N,
    not dilated) and the depth past the first contact (m, NaN when unknown); none when the fit
    stored no profile."""
    if not config.n_force_profile:
        return {}
    n = config.n_force_profile
    return {"force_profile": (n,), "force_normal": (3,), "force_depth": (n, 2)}


def read_config_json(path: Path) -> dict:
    """The checkpoint's ``config.json`` as a dict: a forcemap config that stores every setting the maps
    were fitted with (a missing one would be read as today's default: placement re-solves free
    segments with it, so the numbers would silently differ from the fit)."""
    if not path.is_file():
        raise ValueError(f"{path}: file not found (a checkpoint folder needs config.json)")
    data = read_json_object(path)
    if data.get("type") != "forcemap":
        raise ValueError(f"{path}: field 'type' is {data.get('type')!r}, expected 'forcemap'")
    for name in (*FITTED_FIELDS, *ForceMapConfig.fit_field_names(), "input_features", "output_features"):
        if name not in data and name not in OPTIONAL_FITTED_FIELDS:
            raise ValueError(f"{path}: field {name!r} is missing (not a complete fitted forcemap checkpoint)")
    return data


def check_safetensors_file(path: Path, config: ForceMapConfig) -> None:
    """``path`` holds exactly the tensors ``config`` implies, with their shapes and dtypes; reads the
    header only (the policy's buffers are sized from the config: a tampered count must not allocate)."""
    from safetensors import SafetensorError, safe_open

    if not path.is_file():
        raise ValueError(f"{path}: file not found (a forcemap checkpoint needs it next to config.json)")
    try:
        with safe_open(str(path), framework="pt") as f:
            found = {k: (tuple(f.get_slice(k).get_shape()), f.get_slice(k).get_dtype()) for k in f.keys()}  # noqa: SIM118
    except (SafetensorError, OSError, ValueError) as err:
        raise ValueError(f"{path}: not a readable safetensors file ({err})") from err
    want = expected_tensors(config)
    if set(found) != set(want):
        missing, extra = sorted(set(want) - set(found)), sorted(set(found) - set(want))
        raise ValueError(f"{path}: missing tensor(s) {missing}, unexpected tensor(s) {extra}")
    for name in (name for name in want if found[name] != want[name]):
        raise ValueError(
            f"{path}: tensor {name!r} has shape and dtype {found[name]}, config.json implies {want[name]} "
            f"(n_segments={config.n_segments}, segment_n_nodes={list(config.segment_n_nodes)}, "
            f"segment_n_gripper_nodes={list(config.segment_n_gripper_nodes)})"
        )


def check_processor_files(
    folder: str | Path, *, required: bool, warn_missing: bool = True, raw_values: bool = False
) -> None:
    """The processor pipelines in ``folder`` build only LeRobot's or this plugin's processor steps.

    ``required``: whether the pipelines must be there (``lerobot-eval``, ``forcemap eval`` and ``push``
    load them; ``ForceMapPolicy.from_pretrained`` alone does not); ``warn_missing``: warn about a
    missing optional one (off where the Hub fetch already said why); ``raw_values``: every normaliser
    must map each feature type to IDENTITY (the forcemap policy acts on raw dataset values; a learned
    policy's checkpoint normalises and is checked without it).
    """
    for name in PROCESSOR_FILES:
        path = Path(folder) / name
        if not path.is_file():
            if required:
                raise ValueError(f"{path}: file not found (lerobot-train and forcemap fit write it)")
            if warn_missing:
                logger.warning("%s: file not found; lerobot-eval needs it to run this policy", path)
            continue
        steps = read_json_object(path).get("steps")
        for i, step in enumerate(steps if isinstance(steps, list) else []):
            if not isinstance(step, dict):
                continue  # LeRobot refuses it by itself
            if "registry_name" not in step and "class" in step:
                _check_step_class(str(step["class"]), f"{path}: steps[{i}].class")
            norm_map = (step.get("config") or {}).get("norm_map") or {}
            if raw_values and isinstance(norm_map, dict) and any(m != "IDENTITY" for m in norm_map.values()):
                fail(f"{path}: steps[{i}].config.norm_map", "map every feature type to 'IDENTITY'", norm_map)


def _check_step_class(path: str, where: str) -> None:
    """``path`` (module.Class) names a ``ProcessorStep`` of a trusted module; no other is imported."""
    from lerobot.processor import ProcessorStep

    module_name, _, class_name = path.rpartition(".")
    cls = None
    if module_name.split(".")[0] in TRUSTED_STEP_MODULES:
        with contextlib.suppress(ImportError, AttributeError):
            cls = getattr(importlib.import_module(module_name), class_name)
    if not (isinstance(cls, type) and issubclass(cls, ProcessorStep)):
        what = f"name a ProcessorStep of {' or '.join(TRUSTED_STEP_MODULES)} (LeRobot imports and calls any other"
        fail(where, f"{what} before checking it)", path)


def fetch_hub_checkpoint(repo_id: str, hub_kwargs: dict) -> Path:
    """Download (or find in the local cache) ``config.json``, ``model.safetensors`` and the processor
    pipelines of ``repo_id``; returns their folder, checked then as a local one. ``hub_kwargs``:
    ``hf_hub_download`` arguments (revision, cache_dir, token, local_files_only...)."""
    from huggingface_hub import is_offline_mode
    from huggingface_hub.errors import EntryNotFoundError, HfHubHTTPError, LocalEntryNotFoundError

    def fetch(filename: str, *, required: bool) -> Path | None:
        try:
            return Path(hf_hub_download(repo_id=repo_id, filename=filename, **hub_kwargs))
        except LocalEntryNotFoundError as err:
            if not (is_offline_mode() or hub_kwargs.get("local_files_only")):
                raise ValueError(f"{repo_id}: cannot download {filename} ({err})") from err
            cause, hint = err, "download the checkpoint once online, or pass a local folder"
            missing = f"{filename} is not in the local Hugging Face cache and the Hub is not asked"
        except EntryNotFoundError as err:
            cause, missing = err, f"the repo has no {filename}"
            hint = (
                f"a forcemap checkpoint holds config.json, model.safetensors and {', '.join(PROCESSOR_FILES)}"
            )
        except HfHubHTTPError as err:  # no such repo or revision, no access
            raise ValueError(f"{repo_id}: cannot read {filename} from the Hub ({err})") from err
        if required:
            raise ValueError(f"{repo_id}: {missing}: {hint}") from cause
        logger.warning("%s: %s; lerobot-eval needs it to run this policy", repo_id, missing)
        return None

    folder = fetch("config.json", required=True).parent
    fetch("model.safetensors", required=True)
    for name in PROCESSOR_FILES:
        fetch(name, required=False)
    return folder
