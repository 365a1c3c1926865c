"""Pre/post-processing of the ``forcemap`` policy: LeRobot's default pipeline with identity normalisation.

The policy works in SI units (metres, seconds, newtons, unit quaternions), so every feature type maps
to ``NormalizationMode.IDENTITY`` (``ForceMapConfig.normalization_mapping``) and the normaliser steps
pass values through unchanged. They are kept anyway, with the rename, batch and device steps, because
``lerobot-eval`` and ``lerobot-train --policy.path`` override steps by name
(``device_processor``, ``rename_observations_processor``, ``normalizer_processor``) and fail on a
pipeline that lacks them. Saved with the checkpoint as ``policy_preprocessor.json`` /
``policy_postprocessor.json`` (JSON + safetensors, no pickle).
"""

from __future__ import annotations

from typing import Any

import torch
from lerobot.processor import PolicyAction, PolicyProcessorPipeline, make_default_pre_post_processors

from lerobot_policy_forcemap.configuration_forcemap import ForceMapConfig

__all__ = ["make_forcemap_pre_post_processors"]


def make_forcemap_pre_post_processors(
    config: ForceMapConfig,
    dataset_stats: dict[str, dict[str, torch.Tensor]] | None = None,
) -> tuple[
    PolicyProcessorPipeline[dict[str, Any], dict[str, Any]],
    PolicyProcessorPipeline[PolicyAction, PolicyAction],
]:
    """(preprocessor, postprocessor): rename -> add batch dim -> device -> normalise (identity);
    unnormalise (identity) -> cpu."""
    return make_default_pre_post_processors(config, dataset_stats, normalizer_device=config.device)
