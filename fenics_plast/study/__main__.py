"""``python -m fenics_plast.study SCENE.toml --vary KEY=V1,V2,...`` (see :mod:`fenics_plast.study.cli`)."""
import sys

from .cli import main

sys.exit(main())
