"""Reasoner plug-ins: typed-data interpretation over a scene view (SkiROS discrete reasoners).

- :class:`SpatialReasoner`: world and relative poses, distances, inside / on;
- :func:`classify` / :func:`identify` (:class:`SimilarityReasoner`): which template or which
  known element an observed element resembles;
- :class:`ReasonerSet`: built-ins + ``skimesh.reasoners`` entry points + explicit factories.
"""

from .base import ENTRY_POINT_GROUP as ENTRY_POINT_GROUP
from .base import FrameCycleError as FrameCycleError
from .base import MissingDataError as MissingDataError
from .base import Reasoner as Reasoner
from .base import ReasonerError as ReasonerError
from .base import ReasonerFactory as ReasonerFactory
from .base import ReasonerSet as ReasonerSet
from .similarity import SimilarityReasoner as SimilarityReasoner
from .similarity import classify as classify
from .similarity import identify as identify
from .similarity import property_similarity as property_similarity
from .spatial import SpatialReasoner as SpatialReasoner
from .spatial import Transform as Transform

__all__ = [
    "ENTRY_POINT_GROUP",
    "FrameCycleError",
    "MissingDataError",
    "Reasoner",
    "ReasonerError",
    "ReasonerFactory",
    "ReasonerSet",
    "SimilarityReasoner",
    "SpatialReasoner",
    "Transform",
    "classify",
    "identify",
    "property_similarity",
]
