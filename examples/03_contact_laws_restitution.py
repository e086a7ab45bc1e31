"""One central impact per contact law: the effective restitution (separation speed / approach
speed) each law gives for the restitution ce it is asked for, and the paper's Fig. 3 loops.

    python examples/03_contact_laws_restitution.py [OUTPUT_FOLDER]
"""

from __future__ import annotations

import sys
from pathlib import Path

import vibroimpact as vi
from vibroimpact import plotting
from vibroimpact.impact import single_impact, single_impact_result

out = Path(sys.argv[1] if len(sys.argv) > 1 else "example-output")
out.mkdir(parents=True, exist_ok=True)

K, mass, v0 = 1e9, 1.0, 1.0                                    # N/m^1.5, kg, m/s
print("law                   " + "  ".join(f"ce={ce:<4}" for ce in (0.3, 0.5, 0.7, 0.9)))
for cls in (vi.contact.HuntCrossley, vi.contact.LankaraniNikravesh, vi.contact.Gonthier,
            vi.contact.Flores):
    effective = [single_impact(cls(stiffness=K, restitution=ce), mass=mass,
                               velocity=v0)["restitution_effective"]
                 for ce in (0.3, 0.5, 0.7, 0.9)]
    print(f"{cls.kind:20s}  " + "  ".join(f"{e:7.3f}" for e in effective))

loops = {cls.kind: single_impact_result(cls(stiffness=K, restitution=0.5), mass=mass,
                                        velocity=v0)
         for cls in (vi.contact.LankaraniNikravesh, vi.contact.Flores)}
loops["hertz"] = single_impact_result(vi.contact.Hertz(stiffness=K), mass=mass, velocity=v0)
plotting.compare(loops, "force-indentation", path=out / "loops.png",
                 title="Force against indentation, ce = 0.5")
print(f"wrote {out}/loops.png")
