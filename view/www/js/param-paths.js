// Render parameters are nested objects ("enhanced.transfer.window"); controls name them by path.
export function getPath(object, path) {
  return path.split('.').reduce((o, key) => (o == null ? undefined : o[key]), object);
}

export function setPath(object, path, value) {
  const keys = path.split('.');
  let o = object;
  for (const key of keys.slice(0, -1)) {
    if (typeof o[key] !== 'object' || o[key] === null || Array.isArray(o[key])) o[key] = {};
    o = o[key];
  }
  o[keys[keys.length - 1]] = value;
  return object;
}

// Every leaf path of a changes object ("view.zoom", ...); arrays are leaves.
export function leafPaths(object, prefix = '') {
  return Object.entries(object).flatMap(([key, value]) => {
    const path = prefix ? `${prefix}.${key}` : key;
    return value && typeof value === 'object' && !Array.isArray(value) ? leafPaths(value, path) : [path];
  });
}
