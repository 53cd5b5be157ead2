"""The validity study: where the quasi-static model's answer holds, by speed ratio (``study`` runs it; ``data``,
``figures``, ``report``, ``summary`` read and render its stored files)."""
