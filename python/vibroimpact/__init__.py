"""vibroimpact: the dynamic response of structures with clearance.

Build a :class:`Model` (a :class:`Structure`, :class:`Gap` elements with laws from
:mod:`vibroimpact.contact`, loads, initial conditions), then :func:`simulate` it::

    import vibroimpact as vi
    law = vi.contact.LankaraniNikravesh(stiffness=1.509e11, exponent=1.5, restitution=0.9)
    model = vi.Model(vi.Structure.sdof(mass=100.0),
                     gaps=[vi.Gap(dof=0, clearance=0.005, side="both", law=law)],
                     initial_velocity=8.0)
    result = vi.simulate(model, t_end=0.02, dt=1e-6, method=vi.Newmark())
    result.impacts.to_dataframe()
"""

from vibroimpact import contact as contact
from vibroimpact._core import build_profile as build_profile
from vibroimpact.continuation import Branch as Branch
from vibroimpact.continuation import continue_orbit as continue_orbit
from vibroimpact.errors import ContactResolutionWarning as ContactResolutionWarning
from vibroimpact.errors import Interrupted as Interrupted
from vibroimpact.errors import ModelError as ModelError
from vibroimpact.errors import PreRunWarning as PreRunWarning
from vibroimpact.errors import SolverError as SolverError
from vibroimpact.errors import StepStabilityWarning as StepStabilityWarning
from vibroimpact.integrators import HHT as HHT
from vibroimpact.integrators import Adaptive as Adaptive
from vibroimpact.integrators import Bathe as Bathe
from vibroimpact.integrators import Dop853 as Dop853
from vibroimpact.integrators import EventDriven as EventDriven
from vibroimpact.integrators import GeneralizedAlpha as GeneralizedAlpha
from vibroimpact.integrators import Integrator as Integrator
from vibroimpact.integrators import MoreauJean as MoreauJean
from vibroimpact.integrators import Newmark as Newmark
from vibroimpact.integrators import NewtonOptions as NewtonOptions
from vibroimpact.integrators import PreciseIntegration as PreciseIntegration
from vibroimpact.io import load_model as load_model
from vibroimpact.model import ConstantLoad as ConstantLoad
from vibroimpact.model import Gap as Gap
from vibroimpact.model import HarmonicLoad as HarmonicLoad
from vibroimpact.model import Model as Model
from vibroimpact.model import RadialGap as RadialGap
from vibroimpact.model import Structure as Structure
from vibroimpact.model import TableLoad as TableLoad
from vibroimpact.model import UnbalanceLoad as UnbalanceLoad
from vibroimpact.orbits import PeriodicOrbit as PeriodicOrbit
from vibroimpact.orbits import periodic_orbit as periodic_orbit
from vibroimpact.result import Result as Result
from vibroimpact.simulate import simulate as simulate

__version__ = "0.1.0"
