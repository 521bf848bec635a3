"""``depixel convert``: the command (:mod:`.command`), a batch's jobs and report (:mod:`.batch`),
finding inputs and naming outputs (:mod:`.inputs`), running the jobs (:mod:`.run`) in packs
whose pipelines run in one pass (:mod:`.packs`), standard input and output (:mod:`.stream`),
sprite sheets (:mod:`.sheets`) and the palettes (:mod:`.palette`)."""
