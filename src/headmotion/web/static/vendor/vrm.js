// Third-party code (licences at the end), imported by the pages' modules; built by web/js/build.mjs.
import{a as r,b as e}from"./chunk-3RZZO67R.js";import{a as o}from"./chunk-YWD7VCKZ.js";import"./chunk-NTRQNTM4.js";export{o as GLTFLoader,r as VRMLoaderPlugin,e as VRMUtils};
