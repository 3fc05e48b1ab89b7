import os
from pathlib import Path

import numpy as np
import pytest

os.environ.setdefault("MPLBACKEND", "Agg")

# The authors' real logs sit in ../shared beside the repository (in CI as here), never inside it.
REAL_DATA = Path(os.environ.get("ROBOBALL_REAL_DATA",
                                Path(__file__).resolve().parents[2] / "shared" / "data" / "roboball_real"))
COUPLED = ("steer_coupled_20250429_165825.csv", "steer_coupled_20250429_165853.csv",
           "steer_coupled_20250429_165914.csv")


def real_file(name: str) -> Path:
    """Path of one real log in REAL_DATA; skips the test (saying where it looked) if it is missing."""
    path = REAL_DATA / name
    if not path.exists():
        pytest.skip(f"real log {name} not found in {REAL_DATA}")
    return path


def recording_error(read, path, **flags) -> str:
    """The one-line RecordingError message `read(path, **flags)` raises (fails if it raises none)."""
    from roboball.ingest.errors import RecordingError
    with pytest.raises(RecordingError) as info:
        read(path, **flags)
    return str(info.value)


def fit_damped(t, y):
    """Independent damped-sinusoid fit used to check Drake runs (not the project's extractor)."""
    from scipy.optimize import curve_fit

    t = np.asarray(t, float)
    y = np.asarray(y, float)
    rest0 = np.mean(y[len(y) // 2:])
    yc = y - rest0
    zc = np.where(np.diff(np.sign(yc)) != 0)[0]
    w0 = np.pi / np.mean(np.diff(t[zc])) if len(zc) > 2 else 2.0

    def f(t, A, z, w, ph, c):
        return c + A * np.exp(-z * w * t) * np.cos(w * np.sqrt(1 - z * z) * t + ph)

    p, _ = curve_fit(f, t, y, p0=[y[0] - rest0, 0.01, w0, 0.0, rest0], maxfev=20000)
    return {"amplitude": p[0], "zeta": p[1], "omega_n": p[2], "rest": p[4],
            "rmse": float(np.sqrt(np.mean((f(t, *p) - y) ** 2)))}


@pytest.fixture(scope="session")
def robot():
    from roboball.config import load_robot

    return load_robot()
