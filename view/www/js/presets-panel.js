// Named presets over the HTTP API: the list, save the current parameters under a name, recall,
// delete. Each request carries the operator's token as a Bearer header; a refusal's text shows
// in the panel.
import { authHeaders } from './token.js';

export function attachPresets({ list, nameInput, saveButton, errorElement }, token) {
  const call = async (method, path) => {
    const response = await fetch(path, { method, headers: { ...authHeaders(token),
      'Content-Type': 'application/json' }, body: method === 'GET' ? undefined : '{}' });
    const body = await response.json().catch(() => ({}));
    if (!response.ok || body.ok === false) {
      throw new Error(body.error || `${method} ${path}: HTTP ${response.status}`);
    }
    return body;
  };
  const report = (error) => { errorElement.textContent = error ? error.message : ''; };
  const encoded = (name) => `/api/presets/${encodeURIComponent(name)}`;

  async function refresh() {
    try {
      const body = await call('GET', '/api/presets');
      const names = Array.isArray(body) ? body : (body.presets || body.names || []);
      list.replaceChildren(...names.map((name) => presetRow(name)));
      report(null);
    } catch (error) { report(error); }
  }

  function presetRow(name) {
    const row = document.createElement('li');
    const label = document.createElement('span');
    label.textContent = name;
    const recall = button('Recall', async () => { await call('POST', `${encoded(name)}/recall`); });
    const remove = button('Delete', async () => { await call('DELETE', encoded(name)); await refresh(); });
    row.append(label, recall, remove);
    return row;
  }

  function button(text, action) {
    const b = document.createElement('button');
    b.type = 'button';
    b.textContent = text;
    b.addEventListener('click', async () => {
      try { await action(); report(null); } catch (error) { report(error); }
    });
    return b;
  }

  saveButton.addEventListener('click', async () => {
    const name = nameInput.value.trim();
    if (!name) { report(new Error('give the preset a name')); return; }
    try { await call('PUT', encoded(name)); await refresh(); } catch (error) { report(error); }
  });
  refresh();
}
