// placeholder replaced below
export class Runs {
  constructor(root, app) { this.root = root; this.app = app; }
  async init() {}
}
