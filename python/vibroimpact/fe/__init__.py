"""Multi-DOF structures (issue 6): beam finite elements (:mod:`~vibroimpact.fe.beam`),
imported FE matrices (:mod:`~vibroimpact.fe.matrices`), modal analysis
(:mod:`~vibroimpact.fe.modal`), Craig–Bampton reduction (:mod:`~vibroimpact.fe.reduction`)
and static condensation of massless DOFs (:mod:`~vibroimpact.fe.condensation`).

Example — the paper's hollow shaft (§3.2), its free–free modes and a slider gap::

    import vibroimpact as vi
    from vibroimpact import fe

    shaft = fe.Beam(length=1.0, elements=20,
                    section=fe.Section.tube(outer_diameter=0.190, wall_thickness=0.005),
                    material=fe.Material(youngs_modulus=207e9, poisson=0.3, density=34410.0))
    fe.modes(shaft, 3).elastic_frequencies_hz        # Hz
    gap = shaft.gap(vi.contact.Hertz(stiffness=1.5e11), node="end", direction="x",
                    clearance=0.003)
"""

from vibroimpact.fe import matrices as matrices
from vibroimpact.fe import reduction as reduction
from vibroimpact.fe.beam import Beam as Beam
from vibroimpact.fe.beam import Bearing as Bearing
from vibroimpact.fe.beam import Disc as Disc
from vibroimpact.fe.beam import Material as Material
from vibroimpact.fe.beam import PointMass as PointMass
from vibroimpact.fe.beam import Section as Section
from vibroimpact.fe.beam import Spring as Spring
from vibroimpact.fe.beam import Support as Support
from vibroimpact.fe.beam import cowper_shear_coefficient as cowper_shear_coefficient
from vibroimpact.fe.condensation import StaticCondensation as StaticCondensation
from vibroimpact.fe.condensation import condense_massless as condense_massless
from vibroimpact.fe.damping import ModalDamping as ModalDamping
from vibroimpact.fe.damping import Rayleigh as Rayleigh
from vibroimpact.fe.dofs import DIRECTIONS as DIRECTIONS
from vibroimpact.fe.dofs import DofMap as DofMap
from vibroimpact.fe.dofs import FEStructure as FEStructure
from vibroimpact.fe.modal import Modes as Modes
from vibroimpact.fe.modal import modes as modes
from vibroimpact.fe.modal import plot_mode_shapes as plot_mode_shapes
from vibroimpact.fe.reduction import CraigBampton as CraigBampton
from vibroimpact.fe.reduction import ReductionCheck as ReductionCheck
from vibroimpact.fe.reduction import check_reduction as check_reduction
from vibroimpact.fe.reduction import craig_bampton as craig_bampton
from vibroimpact.fe.reduction import reduce_model as reduce_model
