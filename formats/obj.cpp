// STUB: OBJ loading helpers (to be replaced).
