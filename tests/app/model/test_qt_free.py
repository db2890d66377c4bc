"""The model is plain Python: importing it loads no Qt, pyqtgraph or pyvista."""

import subprocess
import sys


def test_importing_the_model_loads_no_gui_library():
    code = ("import sys, terrasynth_app.model, terrasynth_app.model.feature_graphs; "
            "print(sorted(m for m in sys.modules if m.split('.')[0] in ('PySide6', 'pyqtgraph', 'pyvista', 'vtk')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"
