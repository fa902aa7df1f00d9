// placeholder replaced below
export class Mesh {
  constructor(root, app) { this.root = root; this.app = app; }
  async init() {}
}
