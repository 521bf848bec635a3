"""``depixel diff``: two images (:mod:`.command`) or two folders of renders (:mod:`.folders`)."""
