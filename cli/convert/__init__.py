"""``depixel convert``: the command (:mod:`.command`), a batch's jobs and report (:mod:`.batch`),
finding inputs and naming outputs (:mod:`.inputs`) and running the jobs (:mod:`.run`), in packs
whose pipelines run in one pass (:mod:`.packs`)."""
