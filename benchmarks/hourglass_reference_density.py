"""The 2-D hourglass with the hydrostatic reference (reference_density 1000 = the light
phase, reference_level 1.75 m = the fill height under a 5 cm air gap) at the scene's 25 mm and
at 12.5 mm, two ensemble members each (docs/sph.md, "The hydrostatic reference").

    python benchmarks/hourglass_reference_density.py   [OUT.json]
"""
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from exchange_convergence import hourglass  # noqa: E402

# with the default damping (the scene itself now runs the closed-container damping too)
REFERENCE = {"reference_density": 1000.0, "reference_level": 1.75, "xsph": 0.1, "viscosity": 1e-3}


def main() -> None:
    out = []
    for r in (0.025, 0.0125):
        for seed in (0, 1):
            row = hourglass(r, REFERENCE, seed)
            out.append(row)
            print(json.dumps({k: round(v, 3) if isinstance(v, float) else v
                              for k, v in row.items()}), flush=True)
    path = sys.argv[1] if len(sys.argv) > 1 else "hourglass_reference_density.json"
    with open(path, "w") as f:
        json.dump(out, f, indent=1)


if __name__ == "__main__":
    main()
