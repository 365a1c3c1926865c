"""Rolling policies in the sim tasks and summarising what happened: records, statistics, reports."""
