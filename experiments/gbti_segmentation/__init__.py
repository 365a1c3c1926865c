"""The paper's segmentation experiment on the 60 GBTI grasping demos, and what it should have measured.

The paper's §IV-A, Tables I/II (segment counts for three stream weightings) and Fig. 4:

1. Reproduces Table II: segment count mean ± std over 5 seeds x 60 demos for the weightings of Table I
   (position only, uniform, custom force-heavy) in each combination mode (product, geometric, linear)
   with the paper's sampling changepoints, beside the paper's numbers and a flat-pmf control (a
   segmentation that found no keypoint at all).
2. Scores the changepoints against reference events read off the data (gripper close and open,
   finger contact onset; ``lerobot_forcemap.segmentation.events``): precision / recall / F1 within a
   tolerance (``lerobot_forcemap.segmentation.evaluation``), for every weighting x mode x changepoint
   method (sample, peaks) x derivative (savgol, difference), plus the automatic weights.
3. Draws one demo coloured by segment under the three weightings (like the paper's Fig. 4).

Writes results/segmentation.{md,json,png} and results/segmentation_f1.png.

    .venv/bin/python -m experiments.gbti_segmentation [--data DIR] [--out results]
        [--seeds 5] [--n-points 1000] [--tolerance 64] [--limit N] [--figure-demo KEY]

Demos are resampled to --n-points evenly spaced frames (the authors resampled to 1000 points);
window, tolerance and merge distance are in those frames. Modules: ``data`` (the demos, streams and
weightings), ``configurations`` (one configuration over every demo), ``scoring``, ``study`` (the
analyses), ``figures``, ``report`` (the Markdown, its prose in ``templates/segmentation.md``) and
``__main__`` (the command).
"""
