"""Head motion inside voice-agent frameworks, in the agent's own process (no HTTP hop).

* :mod:`headmotion.live.core` — the transport-independent part: a model and one
  stream per utterance and the settling of the head when an utterance ends or is cut off;
  :mod:`headmotion.live.pacing` sends the frame messages in time with the audio's
  playback.  Both need nothing beyond headmotion.
* :mod:`headmotion.integrations.pipecat` — a Pipecat ``FrameProcessor``
  (``pip install "headmotion[pipecat]"``).
* :mod:`headmotion.integrations.livekit` — a LiveKit Agents ``AudioOutput``
  (``pip install "headmotion[livekit]"``).
* :mod:`headmotion.integrations.reachy` — a Reachy Mini robot's head following the motion
  (``pip install "headmotion[reachy]"``; docs/robots.md); a voice agent drives it with
  ``send=head.send``.

The messages are the JSON messages of ``headmotion serve``'s stream (``{"type": "frames", ...}``
and ``{"type": "end", ...}``, docs/serve.md), so a page that applies the server's frames applies
these too (docs/integrations.md).  Importing this package imports no framework or SDK.
"""

from __future__ import annotations

__all__: list[str] = []
