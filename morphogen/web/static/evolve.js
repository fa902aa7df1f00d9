// placeholder replaced below
export class Evolve {
  constructor(root, app) { this.root = root; this.app = app; }
  async init() {}
}
