// The operator's token travels in the URL fragment (#token=...), which the browser never sends
// to a server; the page hands it over itself, in the WebSocket's hello and as a Bearer header.
export function tokenFromFragment(hash = window.location.hash) {
  return new URLSearchParams(hash.replace(/^#/, '')).get('token') || '';
}

export function authHeaders(token) {
  return token ? { Authorization: `Bearer ${token}` } : {};
}
