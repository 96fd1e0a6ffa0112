# The public API of inertiafit, loaded lazily by lazy_loader.attach_stub (see __init__.py).
from .baseline import paper_baseline
from .errors import (
    ConvergenceWarning,
    InertiafitWarning,
    InputError,
    PriorDataConflictWarning,
    StudyRefused,
)
from .inference.fit import fit, fit_body
from .inference.model import Condition, Model
from .inference.observations import Observation
from .inference.pooling import PopulationPosterior, open_population, population
from .inference.population import Hyperprior
from .inference.priors import Prior, available_priors, load_prior
from .inference.reference import reference_posterior
from .inference.sampler import SamplerSettings, sample
from .io import load_study, read_trial
from .mounting import Mounting
from .pipeline.batch import run_many
from .pipeline.export import run_export
from .pipeline.study import analyse_study, run_study
from .planning.design import Design, NoiseLevels
from .planning.planner import plan
from .posterior import Posterior, open_posterior
from .processing.emg import emg_activity
from .report.propagate import Propagation, propagate

__version__: str

__all__ = [
    "Condition",
    "ConvergenceWarning",
    "Design",
    "Hyperprior",
    "InertiafitWarning",
    "InputError",
    "Model",
    "Mounting",
    "NoiseLevels",
    "Observation",
    "PopulationPosterior",
    "Posterior",
    "Prior",
    "PriorDataConflictWarning",
    "Propagation",
    "SamplerSettings",
    "StudyRefused",
    "__version__",
    "analyse_study",
    "available_priors",
    "emg_activity",
    "fit",
    "fit_body",
    "load_prior",
    "load_study",
    "open_population",
    "open_posterior",
    "paper_baseline",
    "plan",
    "population",
    "propagate",
    "read_trial",
    "reference_posterior",
    "run_export",
    "run_many",
    "run_study",
    "sample",
]
