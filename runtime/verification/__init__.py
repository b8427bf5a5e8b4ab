"""`rapidc verify` at run time: jobs, their runner, the backends that run them (in process, worker
processes, a Dask cluster), the append-only journal of records, and the report and its page."""
