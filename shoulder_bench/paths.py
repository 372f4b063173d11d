"""Where the shipped files live: models/ (MJCF, meshes, muscle tables, reference data), wherever the package runs
from. Its own module so that the model, the force law and the arm all read it without importing one another."""
from __future__ import annotations

from pathlib import Path

MODELS_DIR = Path(__file__).resolve().parent / "models"
if not MODELS_DIR.is_dir():  # source checkout: models/ sits beside the package
    MODELS_DIR = Path(__file__).resolve().parents[1] / "models"
MODEL_PATH = MODELS_DIR / "shoulder.xml"  # model v1
SCENE_PATH = MODELS_DIR / "scene.xml"
