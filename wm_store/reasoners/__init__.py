"""Reasoner plug-ins: typed-data interpretation over a scene view (SkiROS discrete reasoners).

- :class:`SpatialReasoner`: world and relative poses, distances, inside / on;
- :func:`classify` / :func:`identify` (:class:`SimilarityReasoner`): which template or which
  known element an observed element resembles;
- :class:`ReasonerSet`: built-ins + ``skimesh.reasoners`` entry points + explicit factories.
"""

from ._base import ENTRY_POINT_GROUP as ENTRY_POINT_GROUP
from ._base import FrameCycleError as FrameCycleError
from ._base import MissingDataError as MissingDataError
from ._base import Reasoner as Reasoner
from ._base import ReasonerError as ReasonerError
from ._base import ReasonerFactory as ReasonerFactory
from ._base import ReasonerSet as ReasonerSet
from ._similarity import SimilarityReasoner as SimilarityReasoner
from ._similarity import classify as classify
from ._similarity import identify as identify
from ._similarity import property_similarity as property_similarity
from ._spatial import SpatialReasoner as SpatialReasoner
from ._spatial import Transform as Transform
from ._spatial import quat_from_axes as quat_from_axes
from ._spatial import quat_from_yaw as quat_from_yaw
from ._spatial import quat_multiply as quat_multiply
from ._spatial import quat_rotate as quat_rotate

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
    "quat_from_axes",
    "quat_from_yaw",
    "quat_multiply",
    "quat_rotate",
]
