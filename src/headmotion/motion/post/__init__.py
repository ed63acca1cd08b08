"""The post-processing chain every synthesis system runs after its raw output: band and variance
restoration with posture drift (:mod:`.restore`), speed shaping (:mod:`.speed_shaping`), the soft
range limit (:mod:`.range_limit`), pause settling (:mod:`headmotion.motion.pauses`) and amplitude
matching, as one chain (:class:`PostChain`) configured by one dataclass of fitted tables
(:class:`PostTables`); ``docs/decisions/post-chain.md`` says why each stage is there."""

from .chain import DNN_ORDER, LE2012_ORDER, STAGES, TEMPLATE_ORDER, PostChain, PostTables

__all__ = ["PostChain", "PostTables", "DNN_ORDER", "TEMPLATE_ORDER", "LE2012_ORDER", "STAGES"]
