"""Reading and writing vibroimpact files: model files (TOML), see
:mod:`vibroimpact.io.model_file` and ``docs/model-file.md``."""

from vibroimpact.io.model_file import ModelFile as ModelFile
from vibroimpact.io.model_file import ModelFileError as ModelFileError
from vibroimpact.io.model_file import load_model as load_model
from vibroimpact.io.model_file import render_reference as render_reference

__all__ = ["ModelFile", "ModelFileError", "load_model", "render_reference"]
