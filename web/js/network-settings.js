// SPDX-License-Identifier: Apache-2.0
// The network page's settings panel (docs/observability.md): a module's declared config keys
// with their types, ranges, descriptions and values, as ADMIN module_config answers them (the
// answer of flowctl module config), and a form that applies changes through the module's
// reconfigure step (or a restart), and saves them in the config file when asked. Administrators
// only: the page's account must be one (server.web.page_account). The helpers at the top are pure
// (tests/web/network_model.test.mjs runs them in node).
import { jsonText } from './network-model.js';

// A key's rule in words: "integer, 1 to 3600000, default 1000, required".
export function settingRule(key) {
  const parts = [key.type];
  const n = (v) => jsonText(v);
  if (key.min !== undefined && key.max !== undefined) parts.push(`${n(key.min)} to ${n(key.max)}`);
  else if (key.min !== undefined) parts.push(`at least ${n(key.min)}`);
  else if (key.max !== undefined) parts.push(`at most ${n(key.max)}`);
  if (key.choices) parts.push(`one of ${key.choices.map(n).join(', ')}`);
  if (key.default !== undefined) parts.push(`default ${n(key.default)}`);
  if (key.required) parts.push('required');
  return parts.join(', ');
}

// What a field holds, as the key's type wants it: a boolean from a checkbox, a number from a
// number field, a string as typed, anything else as JSON. Throws a message for what cannot be
// one (the hub checks ranges and choices, and says so).
export function parseSetting(key, input) {
  switch (key.type) {
    case 'boolean':
      return Boolean(input);
    case 'string':
      return String(input);
    case 'integer':
    case 'number': {
      const text = String(input).trim();
      const v = Number(text);
      if (text === '' || !Number.isFinite(v)) throw new Error(`${key.key}: "${input}" is not a number`);
      if (key.type === 'integer' && !Number.isSafeInteger(v)) {
        throw new Error(`${key.key}: "${input}" is not an integer`);
      }
      return v;
    }
    default:
      try {
        return JSON.parse(String(input));
      } catch (e) {
        throw new Error(`${key.key}: not JSON (${e.message})`);
      }
  }
}

// The text a field starts with for a value (undefined: empty, the default shows as a hint).
function fieldText(key, value) {
  if (value === undefined) return '';
  if (key.type === 'string' && typeof value === 'string') return value;
  return jsonText(value) ?? '';
}

const element = (tag, props = {}) => Object.assign(document.createElement(tag), props);

export class SettingsPanel {
  // `hub`: the library's Hub; `$`: the page's elements by id (web/network/index.html).
  constructor(hub, $) {
    this.hub = hub;
    this.$ = $;
    this.module = null;  // the module shown
    this.keys = [];      // its declared keys, as last answered
    this.asked = 0;      // answers to older requests are dropped
    $('settings-form').addEventListener('submit', (e) => {
      e.preventDefault();
      this.apply(false);
    });
    $('settings-save').addEventListener('click', () => this.apply(true));
  }

  // Shows the settings of module `name` (null: hides the panel).
  show(name) {
    if (name === this.module) return;
    this.module = name;
    this.$('settings').hidden = !name;
    this.$('settings-form').hidden = true;
    this.status('', true);
    if (name) this.load(`loading the settings of ${name}…`);
  }

  async load(note) {
    const name = this.module;
    const asked = ++this.asked;
    this.$('settings-note').textContent = note;
    try {
      const answer = await this.hub.admin('module_config', { name });
      if (asked !== this.asked) return;
      this.keys = answer.keys;
      this.render();
    } catch (e) {
      if (asked !== this.asked) return;
      this.$('settings-form').hidden = true;
      this.$('settings-note').textContent = e.code === 'permission_denied'
        ? `Only an administrator sees and changes a module's settings; this page logs in as ` +
          `${this.hub.session?.user} (server.web.page_account, docs/observability.md).`
        : `${name}'s settings: ${e.code ?? 'error'}: ${e.message}`;
    }
  }

  render() {
    const body = this.$('settings-keys').tBodies[0];
    body.replaceChildren(...this.keys.map((k) => {
      const tr = element('tr');
      tr.dataset.key = k.key;
      let input;
      if (k.type === 'boolean') {
        input = element('input', { type: 'checkbox', checked: Boolean(k.value ?? k.default) });
      } else if (k.choices) {
        input = element('select');
        input.append(...k.choices.map((c) => element('option', { value: String(c), textContent: String(c) })));
        input.value = String(k.value ?? k.default ?? k.choices[0]);
      } else {
        const numeric = k.type === 'integer' || k.type === 'number';
        input = element('input', { type: numeric ? 'number' : 'text', value: fieldText(k, k.value) });
        if (numeric) {
          input.step = k.type === 'integer' ? '1' : 'any';
          if (k.min !== undefined) input.min = String(k.min);
          if (k.max !== undefined) input.max = String(k.max);
        }
        if (k.default !== undefined) input.placeholder = fieldText(k, k.default);
      }
      input.setAttribute('aria-label', k.key);
      input.dataset.key = k.key;
      input.addEventListener('input', () => tr.classList.add('changed'));
      input.addEventListener('change', () => tr.classList.add('changed'));
      const name = element('td', { textContent: k.key, title: k.description });
      const field = element('td');
      field.append(input);
      const about = element('td', { className: 'muted' });
      about.append(element('div', { textContent: settingRule(k) }), element('div', { textContent: k.description }));
      tr.append(name, field, about);
      return tr;
    }));
    this.$('settings-note').textContent = this.keys.length === 0
      ? `${this.module} declares no settings.`
      : `${this.module}'s declared settings: a change is applied at once (in place when the module can, ` +
        'else by restarting it); "apply and save" also writes it into the config file.';
    this.$('settings-form').hidden = this.keys.length === 0;
  }

  // Sends the changed fields (`save`: written into the config file too).
  async apply(save) {
    const set = {};
    try {
      for (const tr of this.$('settings-keys').tBodies[0].rows) {
        if (!tr.classList.contains('changed')) continue;
        const key = this.keys.find((k) => k.key === tr.dataset.key);
        const input = tr.querySelector('[data-key]');
        set[key.key] = parseSetting(key, key.type === 'boolean' ? input.checked : input.value);
      }
    } catch (e) {
      this.status(e.message, false);
      return;
    }
    if (Object.keys(set).length === 0) {
      this.status('nothing changed', true);
      return;
    }
    const name = this.module;
    this.status(`applying ${Object.keys(set).join(', ')}…`, true);
    try {
      const a = await this.hub.admin('module_config', { name, set, save });
      if (name !== this.module) return;
      this.status(`${a.module} ${a.applied}${a.saved ? `, saved in ${a.saved}` : ''}`, true);
      this.load(this.$('settings-note').textContent);
    } catch (e) {
      if (name === this.module) this.status(`${e.code ?? 'error'}: ${e.message}`, false);
    }
  }

  status(text, ok) {
    this.$('settings-status').textContent = text;
    this.$('settings-status').className = ok ? 'ok' : 'error';
  }
}
