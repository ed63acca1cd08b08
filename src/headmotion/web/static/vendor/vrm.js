// Third-party code (licences at the end), imported by viewer.js and avatar.js; built by web/js/build.mjs.
import{a as o,b as r,c as e}from"./chunk-VFMJUAV3.js";import"./chunk-SS6ETLV5.js";export{o as GLTFLoader,r as VRMLoaderPlugin,e as VRMUtils};
