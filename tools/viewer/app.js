// The web entry of Foxglove Studio 1.48 (packages/studio-web of the foxglove/studio repository), in plain
// JavaScript over studio-base's prebuilt bundle: app settings in localStorage, layouts in memory, read
// from `layouts/` beside this page (open one with `?layoutId=<id>`), no extensions.
/* global React, ReactDOM */
(function main() {
  const studio = window; // the UMD bundle put its exports on window
  const settingsKey = "coordarm.viewer.settings";

  class LocalStorageAppConfiguration {
    constructor(defaults) {
      this.values = { ...defaults, ...JSON.parse(localStorage.getItem(settingsKey) || "{}") };
      this.listeners = new Map();
    }
    get(key) { return this.values[key]; }
    async set(key, value) {
      this.values[key] = value;
      localStorage.setItem(settingsKey, JSON.stringify(this.values));
      for (const cb of this.listeners.get(key) || []) { cb(value); }
    }
    addChangeListener(key, cb) {
      if (!this.listeners.has(key)) { this.listeners.set(key, new Set()); }
      this.listeners.get(key).add(cb);
    }
    removeChangeListener(key, cb) { this.listeners.get(key)?.delete(cb); }
  }

  // Layouts: `layouts/index.json` lists the ids of the served layouts `layouts/<id>.json` (Foxglove's
  // layout export format); the layout manager lists a namespace once and keeps it in memory.
  class ServedLayoutStorage {
    constructor() { this.layouts = new Map(); this.served = undefined; }
    async loadServed() {
      const response = await fetch("layouts/index.json");
      const ids = response.ok ? await response.json() : [];
      const layouts = [];
      for (const id of ids) {
        const data = await (await fetch(`layouts/${encodeURIComponent(id)}.json`)).json();
        layouts.push({
          id, name: id, permission: "CREATOR_WRITE",
          baseline: { data, savedAt: new Date().toISOString() }, working: undefined, syncInfo: undefined,
        });
      }
      return layouts;
    }
    async list(namespace) {
      if (!this.layouts.has(namespace)) {
        this.served = this.served || this.loadServed();
        this.layouts.set(namespace, new Map((await this.served).map((l) => [l.id, l])));
      }
      return [...this.layouts.get(namespace).values()];
    }
    async get(namespace, id) { await this.list(namespace); return this.layouts.get(namespace).get(id); }
    async put(namespace, layout) { await this.list(namespace); this.layouts.get(namespace).set(layout.id, layout); return layout; }
    async delete(namespace, id) { await this.list(namespace); this.layouts.get(namespace).delete(id); }
    async importLayouts() {}
  }

  const S = studio.AppSetting;
  const appConfiguration = new LocalStorageAppConfiguration({
    [S.LAUNCH_PREFERENCE]: "web",
    [S.HIDE_SIGN_IN_PROMPT]: true,
    [S.TELEMETRY_ENABLED]: false,
    [S.CRASH_REPORTING_ENABLED]: false,
    [S.UPDATES_ENABLED]: false,
    [S.SHOW_OPEN_DIALOG_ON_STARTUP]: false,
    [S.TIME_FORMAT]: "SEC",
    [S.COLOR_SCHEME]: "light",
  });
  const dataSources = [
    new studio.RemoteDataSourceFactory(),
    new studio.FoxgloveWebSocketDataSourceFactory(),
    new studio.McapLocalDataSourceFactory(),
  ];

  // The 3D panel's one-time hint ("Open settings to configure topics and layers") covers the view; a
  // user dismisses it once, and the app keeps that in its profile.
  if (localStorage.getItem("studio.profile-data") === null) {
    localStorage.setItem("studio.profile-data",
      JSON.stringify({ onboarding: { settingsTooltipShownForPanelTypes: ["3D"] } }));
  }

  studio.overwriteFetch();
  studio.initI18n().then(() => {
    ReactDOM.render(
      React.createElement(studio.App, {
        deepLinks: [window.location.href],
        appConfiguration,
        dataSources,
        layoutStorage: new ServedLayoutStorage(),
        extensionLoaders: [],
        enableGlobalCss: true,
      }),
      document.getElementById("root"),
    );
  });
})();
