"""``depixel inkscape``: install, remove and check the Inkscape extension (:mod:`.command`,
:mod:`.python`); the extension itself is the folder ``extension/`` (package data)."""
