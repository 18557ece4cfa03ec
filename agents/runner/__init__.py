"""The one job runner (process pool, crash retry, resumable JSONL log, Ray) and typed records."""
