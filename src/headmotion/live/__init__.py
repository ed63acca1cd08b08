"""Live head motion: audio inputs, a streaming session and real-time outputs (issue 16).

* :mod:`.inputs`    — PCM on stdin, audio files (optionally paced), microphone (sounddevice);
* :mod:`.session`   — input → motion stream → outputs, bounded queues, end-to-end latency;
* :mod:`.frames`    — the frame record (the JSON line of ``headmotion stream``) and JSON lines;
* :mod:`.vmc`       — VMC protocol over OSC/UDP (VSeeFace, Warudo, VMagicMirror, EVMC4U);
* :mod:`.websocket` — frames to any number of WebSocket clients.

The streaming features these rely on for low latency are in :mod:`headmotion.features.streaming`.
python-osc, websockets and sounddevice are the ``live`` extra; each is imported only when used.
"""
