"""``depixel convert --dask``: a batch as tasks on a Dask cluster (:mod:`.batch`), the cluster's
checks (:mod:`.cluster`) and what a worker runs (:mod:`.task`)."""
