"""A test aiding node: ``fix_relay`` republishes ``gnss/fix`` on its own topic
with its covariance scaled, and the fusion node takes it through this
package's source type ``relay_fix``. Everything it needs is in this package
(``descriptor.py``, ``converter.py``, ``node.py``) and its scenario file."""
