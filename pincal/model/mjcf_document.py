"""The MJCF document read from its file, its ``<include>`` files inlined (:mod:`pincal.model.mjcf`)."""

from __future__ import annotations

from pathlib import Path

from lxml import etree

from pincal import files
from pincal.errors import UrdfError

MAX_MJCF_BYTES = 16 * 2**20
"""Largest MJCF file read (16 MiB, includes counted each)."""
MAX_MJCF_ELEMENTS = 200_000
"""Most XML elements in an MJCF model (includes inlined)."""
MAX_INCLUDE_DEPTH = 8
"""Deepest nesting of ``<include>`` files."""


def read_document(path: Path, remove_comments: bool = True) -> etree._ElementTree:
    """The MJCF document of ``path`` with its ``<include>`` elements replaced by the included
    files' content; a one-line UrdfError when it cannot be read."""
    tree = _parse_file(path, remove_comments)
    _inline(tree.getroot(), path.resolve().parent, 0, remove_comments)
    count = sum(1 for _ in tree.getroot().iter())
    if count > MAX_MJCF_ELEMENTS:
        raise UrdfError(f"MJCF {str(path)!r} has {count} elements, more than the {MAX_MJCF_ELEMENTS} allowed")
    return tree


def _parse_file(path: Path, remove_comments: bool) -> etree._ElementTree:
    text = files.read_text(path, "MJCF", UrdfError, max_bytes=MAX_MJCF_BYTES, strict_utf8=False)
    parser = etree.XMLParser(remove_comments=remove_comments, resolve_entities=False)
    try:
        tree = etree.ElementTree(etree.fromstring(text.encode("utf-8"), parser))
    except etree.XMLSyntaxError as exc:
        message = " ".join(str(exc).split())
        raise UrdfError(f"cannot read MJCF {str(path)!r}: not well-formed XML ({message})") from None
    if tree.getroot().tag != "mujoco":
        raise UrdfError(f"MJCF {str(path)!r}: the root element is <{tree.getroot().tag}>, not <mujoco>")
    return tree


def _inline(root: etree._Element, folder: Path, depth: int, remove_comments: bool) -> None:
    for include in list(root.iter("include")):
        name = include.get("file")
        if not name:
            raise UrdfError("MJCF: an <include> without a file")
        if depth >= MAX_INCLUDE_DEPTH:
            raise UrdfError(f"MJCF: <include file={name!r}> nested more than {MAX_INCLUDE_DEPTH} deep")
        included = _parse_file(folder / name, remove_comments).getroot()
        _inline(included, folder, depth + 1, remove_comments)
        parent = include.getparent()
        assert parent is not None  # an <include> inside the document
        at = parent.index(include)
        for offset, child in enumerate(list(included)):
            parent.insert(at + offset, child)
        parent.remove(include)
