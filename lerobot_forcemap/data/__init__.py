"""Real force recordings as LeRobot v3 datasets (floor 2: may import LeRobot, never MuJoCo).

Modules (import them directly; this package imports nothing heavy):

- ``schema``     feature dicts (names from ``layout``), frame/episode validation, dataset cards
- ``recorder``   lab-recorder h5 and GBTI file reader (pure h5py/NumPy)
- ``transforms`` tare, tool->base rotation, duplicate-timestamp cleaning, alignment/resampling
- ``convert``    ``forcemap convert``: h5 -> LeRobot dataset
- ``segment``    ``forcemap segment``: segments written back (per-frame ``segment_index`` + subtasks)
- ``hub``        push a dataset with our card to the Hugging Face Hub
"""
