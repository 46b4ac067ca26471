# SPDX-License-Identifier: GPL-3.0-or-later
"""The one status store: messages the panel shows for a face, per channel.

A channel is the part of the add-on that found the problem (the frame stage, a wrinkle
source, a binding of the expression table).  Handlers never raise; they leave a message
here instead.  Keyed by ``Object.session_uid``, so no ``bpy`` object is held.
"""

_messages = {}  # session_uid -> {channel: message}


def set(face, channel, message):  # noqa: A001 - the store's verb
    """Set (or, with an empty message, clear) ``face``'s message on ``channel``."""
    uid = face.session_uid
    if message:
        _messages.setdefault(uid, {})[channel] = message
    else:
        per_face = _messages.get(uid)
        if per_face is not None:
            per_face.pop(channel, None)
            if not per_face:
                del _messages[uid]


def get(face, channel=None, *, family=False):
    """The message of one channel, or all of ``face``'s messages joined (empty: none).
    ``family``: also the channels named ``<channel>.<part>`` (a source's sub-channels)."""
    per_face = _messages.get(face.session_uid, {})
    if channel is not None and not family:
        return per_face.get(channel, "")
    keys = [c for c in sorted(per_face) if channel is None or c == channel or c.startswith(channel + ".")]
    return "; ".join(per_face[c] for c in keys if per_face[c])


def clear(face=None):
    """Forget ``face``'s messages, or every message (file load, unregister)."""
    if face is None:
        _messages.clear()
    else:
        _messages.pop(face.session_uid, None)
