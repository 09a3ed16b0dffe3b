"""Metadata digests: a map's root and arm metadata sealed at write time, checked at every open.

The root metadata holds, under :data:`DIGEST_KEY`, the SHA-256 of the canonical JSON
of the root itself (without that entry) and of every arm's metadata, which in turn
holds the CRC32 of every value and witness chunk: one chain from the root to every
stored byte a result depends on. Beside each document digest, a short digest of
every leaf (dotted key path, e.g. ``grid.origin``) names the key that changed.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from placement.errors import MapError

DIGEST_KEY = "digests"
ALGORITHM = "sha256"
_LEAF_HEX = 16  # 64 bits per key: enough to name the changed key; the document digest decides


def canonical(doc: object) -> bytes:
    """The canonical JSON bytes of ``doc`` (sorted keys, no spaces)."""
    return json.dumps(doc, sort_keys=True, separators=(",", ":"), ensure_ascii=True, allow_nan=True).encode()


def _leaves(doc: object, prefix: str = "") -> Iterator[tuple[str, object]]:
    if isinstance(doc, dict) and doc:
        for k in sorted(doc):
            yield from _leaves(doc[k], f"{prefix}{k}.")
    else:
        yield prefix[:-1], doc


def document_digest(doc: dict[str, Any]) -> dict[str, Any]:
    """{"document": sha256 hex, "keys": {key path: short hex}} of a metadata document."""
    return {
        "document": hashlib.sha256(canonical(doc)).hexdigest(),
        "keys": {k: hashlib.sha256(canonical(v)).hexdigest()[:_LEAF_HEX] for k, v in _leaves(doc)},
    }


def seal(root: dict[str, Any], metas: dict[str, dict[str, Any]]) -> dict[str, Any]:
    """``root`` with its :data:`DIGEST_KEY` entry covering itself and the arm metadata ``metas`` (arm -> meta,
    exactly as stored and read back)."""
    body = {k: v for k, v in root.items() if k != DIGEST_KEY}
    body = json.loads(json.dumps(body))  # as it will read back
    return {
        **body,
        DIGEST_KEY: {
            "algorithm": ALGORITHM,
            "root": document_digest(body),
            "arms": {arm: document_digest(m) for arm, m in metas.items()},
        },
    }


def _changed_key(doc: dict[str, Any], sealed: dict[str, Any]) -> str | None:
    keys = sealed.get("keys")
    if not isinstance(keys, dict):
        keys = {}
    now: dict[str, str] = document_digest(doc)["keys"]
    for k in sorted(set(now) | set(keys)):
        if now.get(k) != keys.get(k):
            return str(k)
    return None


def check_document(where: str, doc: dict[str, Any], sealed: object) -> None:
    """MapError naming the changed key unless ``doc`` matches its ``sealed`` digest entry."""
    if not isinstance(sealed, dict) or not isinstance(sealed.get("document"), str):
        raise MapError(f"{where} has no digest (the digest table is corrupt); rebuild the map")
    if hashlib.sha256(canonical(doc)).hexdigest() == sealed["document"]:
        return
    key = _changed_key(doc, sealed)
    what = f"key '{key}' changed" if key is not None else "its digest changed"
    raise MapError(f"{where} does not match its digest ({what} after the build: corrupt); rebuild the map")


def digests(path: Path | str, root: dict[str, Any]) -> dict[str, Any] | None:
    """The digest table of a root (None if it has none: a map written before digests); MapError if malformed."""
    table = root.get(DIGEST_KEY)
    if table is None:
        return None
    if not (isinstance(table, dict) and table.get("algorithm") == ALGORITHM and isinstance(table.get("arms"), dict)):
        raise MapError(f"{path}: the metadata digest table is malformed (corrupt); rebuild the map")
    return table


def check_root_digest(path: Path | str, root: dict[str, Any]) -> bool:
    """Check the root metadata against its digest; False if the map has no digests at all."""
    table = digests(path, root)
    if table is None:
        return False
    check_document(f"{path}: root metadata", {k: v for k, v in root.items() if k != DIGEST_KEY}, table.get("root"))
    return True


def check_arm_digest(path: Path | str, root: dict[str, Any], arm: str, meta: dict[str, Any]) -> None:
    """Check an arm's metadata against the digest the root holds for it (no-op for a map without digests)."""
    table = digests(path, root)
    if table is not None:
        check_document(f"{path}: metadata of arm '{arm}'", meta, table["arms"].get(arm))
