"""The one job runner (pool, crash retry, resumable JSONL log, Ray), typed records, tables."""
