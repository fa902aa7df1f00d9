// Explore's parameter maps: a PNG's grey levels as one parameter's spatial field (low value at
// black, high at white, resampled onto the grid on the server). A mapped parameter's slider is
// disabled behind a "map" badge; clicking the badge makes it a number again. The page address
// and the run file hold numbers only, so the run-file link is hidden while a map is set.

import { api, el, fillSelect, fmt, showError } from './api.js';

export class ParamMaps {
  constructor(x) {
    this.x = x;
    this.$ = x.$;
  }

  bind() {
    this.$('ex-map-param').addEventListener('change', () => this.defaults());
    this.$('ex-map-image').addEventListener('change', () => this.upload());
  }

  // after every state: the parameter menu, mapped sliders behind their badges, the run-file link
  onState(state) {
    const box = this.$('ex-map-param');
    const names = Object.keys(state.params);
    if ([...box.options].map((o) => o.value).join() !== names.join()) {
      const keep = box.value;
      fillSelect(box, names, names.includes(keep) ? keep : names[0]);
      this.defaults();
    }
    const maps = state.maps || {};
    for (const [name, inp] of Object.entries(this.x.paramInputs || {})) {
      const info = maps[name];
      inp.range.disabled = Boolean(info);
      inp.num.hidden = Boolean(info);
      let badge = inp.num.parentNode.querySelector('.map-badge');
      if (info && !badge) {
        badge = el('button', { type: 'button', class: 'map-badge', 'data-map': name, text: 'map ×' });
        badge.addEventListener('click', () => this.clear(name));
        inp.num.after(badge);
      }
      if (!badge) continue;
      badge.hidden = !info;
      if (info) {
        badge.title = `${name} is a map from an image: ${fmt(info.lo)} at black to ${fmt(info.hi)} `
          + `at white (${info.resample}); click to make it the slider's number again`;
      }
    }
    const mapped = Object.keys(maps).length > 0;
    this.$('ex-save-run').hidden = mapped;
    this.$('ex-map-norun').hidden = !mapped;
  }

  // the chosen parameter's slider range as the map's low and high values
  defaults() {
    const p = this.x.model?.params.find((q) => q.name === this.$('ex-map-param').value);
    if (!p) return;
    this.$('ex-map-lo').value = fmt(Number(p.min));
    this.$('ex-map-hi').value = fmt(Number(p.max));
  }

  async upload() {
    const input = this.$('ex-map-image');
    const file = input.files[0];
    if (!file || !this.x.sid) return;
    const png = await new Promise((resolve) => {
      const reader = new FileReader();
      reader.onload = () => resolve(reader.result);
      reader.readAsDataURL(file);
    });
    input.value = '';
    const body = { param: this.$('ex-map-param').value, png, resample: this.$('ex-map-resample').value,
      lo: Number(this.$('ex-map-lo').value), hi: Number(this.$('ex-map-hi').value) };
    await this.send(() => api(`/api/live/${this.x.sid}/map`, { method: 'POST', body }));
  }

  clear(name) {
    return this.send(() => api(`/api/live/${this.x.sid}/map/${encodeURIComponent(name)}`, { method: 'DELETE' }));
  }

  // a change to the session, in order with the page's others (Explore.inOrder)
  async send(request) {
    try {
      const res = await this.x.inOrder(request);
      this.x.state = { ...this.x.state, ...res };
      this.x.setDt(res.dt, res.dt_max);
      showError(this.$('ex-error'), '');
      showError(this.$('ex-notice'), res.notices.join('\n'));
      this.onState(this.x.state);
    } catch (err) { this.x.fail(err); }
  }
}
